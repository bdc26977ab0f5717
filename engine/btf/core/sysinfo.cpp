#include <btf/core/error.h>
#include <btf/core/sysinfo.h>
#include <sys/statvfs.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace btf {

namespace {
uint64_t statusKb(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  const std::string k(key);
  while (std::getline(f, line)) {
    if (line.rfind(k, 0) == 0) {
      std::istringstream s(line.substr(k.size()));
      uint64_t kb = 0;
      s >> kb;
      return kb * 1024;
    }
  }
  return 0;
}
}  // namespace

uint64_t peakRssBytes() {
  return statusKb("VmHWM:");
}
uint64_t currentRssBytes() {
  return statusKb("VmRSS:");
}

uint64_t freeDiskBytes(const std::string& path) {
  namespace fs = std::filesystem;
  fs::path p = fs::absolute(path);
  while (!p.empty() && !fs::exists(p)) p = p.parent_path();
  struct statvfs st;
  if (p.empty() || statvfs(p.c_str(), &st) != 0) return 0;
  return uint64_t(st.f_bavail) * st.f_frsize;
}

uint64_t parseBytes(const std::string& text) {
  size_t i = 0;
  double v = 0;
  try {
    v = std::stod(text, &i);
  } catch (...) {
    throw Error("invalid size '" + text +
                "': expected a number with an optional K, M, G or T suffix");
  }
  std::string unit = text.substr(i);
  for (auto& c : unit) c = char(std::toupper(static_cast<unsigned char>(c)));
  double mult = 1;
  if (unit.empty() || unit == "B")
    mult = 1;
  else if (unit == "K" || unit == "KB" || unit == "KIB")
    mult = 1024.0;
  else if (unit == "M" || unit == "MB" || unit == "MIB")
    mult = 1024.0 * 1024;
  else if (unit == "G" || unit == "GB" || unit == "GIB")
    mult = 1024.0 * 1024 * 1024;
  else if (unit == "T" || unit == "TB" || unit == "TIB")
    mult = 1024.0 * 1024 * 1024 * 1024;
  else
    throw Error("invalid size '" + text + "': unknown unit '" + unit + "' (use K, M, G or T)");
  if (!std::isfinite(v) || v <= 0) throw Error("invalid size '" + text + "': must be positive");
  return uint64_t(v * mult);
}

std::string formatBytes(double b) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  int u = 0;
  while (b >= 1024 && u < 4) {
    b /= 1024;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", b, units[u]);
  return buf;
}

std::string formatSeconds(double s) {
  char buf[64];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%.1f s", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%d min %02d s", int(s / 60), int(s) % 60);
  else
    std::snprintf(buf, sizeof buf, "%d h %02d min", int(s / 3600), (int(s) % 3600) / 60);
  return buf;
}

}  // namespace btf
