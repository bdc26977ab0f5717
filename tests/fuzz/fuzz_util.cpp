#include <btf/compress/codec.h>
#include <btf/core/container.h>
#include <btf/core/error.h>
#include <btf/core/hash.h>
#include <btf/ops/ops.h>
#include <btf/store/btf_store.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "fuzz.h"

namespace btf::fuzz {

std::string lastError;

std::string inputDir() {
  static const std::string dir = [] {
    const char* t = std::getenv("TMPDIR");
    std::string d = std::string(t && *t ? t : "/tmp") + "/btf-fuzz-" + kTargetName + "-" +
                    std::to_string(::getpid());
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

std::string writeInput(const uint8_t* data, size_t size, const std::string& ext) {
  const std::string path = inputDir() + "/input." + ext;
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  f.close();
  if (!f) fail("cannot write the input file " + path);
  return path;
}

std::string sceneWithFile(const std::string& type, const std::string& key,
                          const std::string& path) {
  const std::string scene = inputDir() + "/scene.json";
  std::ofstream(scene) << R"({"btfscene": 1, "tile": {"size": [1, 1]},
  "materials": {"m": {"type": "lambert", "albedo": 0.5}},
  "parts": [{"type": ")"
                       << type << R"(", "material": "m", ")" << key << R"(": )"
                       << nlohmann::json(path).dump() << "}]}";
  return scene;
}

void fail(const std::string& what) {
  std::fprintf(stderr, "fuzz target %s: contract broken: %s\n", kTargetName, what.c_str());
  std::fflush(stderr);
  std::abort();
}

void runOne(const uint8_t* data, size_t size) {
  lastError.clear();
  try {
    btfFuzzOne(data, size);
  } catch (const Error& e) {
    lastError = e.what();
    if (lastError.empty()) fail("a btf::Error with no message");
  } catch (const std::exception& e) {
    fail(std::string("an exception that is not a btf::Error escaped: ") + e.what());
  }
}

namespace {

void put64(std::string& b, size_t at, uint64_t v) {
  std::memcpy(b.data() + at, &v, 8);
}

// The header after the 24-byte preamble, when its length fits the file.
bool headerOf(const std::string& b, std::string* header) {
  if (b.size() < container::kPreambleBytes) return false;
  uint64_t len;
  std::memcpy(&len, b.data() + 8, 8);
  if (len > b.size() - container::kPreambleBytes) return false;
  *header = b.substr(container::kPreambleBytes, len);
  return true;
}

void repairBtf(std::string& b) {
  std::string header;
  if (!headerOf(b, &header)) return;
  put64(b, 16, checksum64(header));
  BtfInfo info;
  try {
    info = infoFromJson(header, "repair");
  } catch (const std::exception&) {
    return;
  }
  if (info.texels() > (1 << 20) || info.nDirs() > 4096) return;
  const BtfLayout l = BtfLayout::of(info, header.size());
  if (l.totalBytes != b.size()) return;
  // Table entries {checksum, state}; chunks marked done get the checksum of their bytes.
  for (int c = 0; c < info.chunks(); ++c) {
    const uint64_t at = l.tableOffset + 16 * uint64_t(c);
    uint64_t state;
    std::memcpy(&state, b.data() + at + 8, 8);
    if (state != 0x454e4f44u) continue;
    const uint64_t bytes = uint64_t(info.chunkEnd(c) - info.chunkBegin(c)) * info.texelBytes();
    put64(b, at, checksum64(b.data() + l.chunkOffset(info, c), bytes));
  }
  if (l.vmfBytes > 0)
    put64(b, l.vmfOffset + l.vmfBytes, checksum64(b.data() + l.vmfOffset, l.vmfBytes));
}

void repairCbtf(std::string& b) {
  std::string header;
  if (!headerOf(b, &header)) return;
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(header, nullptr, false);
  if (!j.is_discarded() && j.is_object() && j.contains("arrays") && j["arrays"].is_array()) {
    // Each array's checksum is patched in the header text, in place (16 hex digits after the
    // k-th "checksum" key of the arrays list), so the header keeps its length and the arrays
    // their absolute offsets.
    size_t at = header.find("\"arrays\"");
    for (auto& a : j["arrays"]) {
      if (at == std::string::npos) break;
      at = header.find("\"checksum\"", at);
      if (at == std::string::npos) break;
      at = header.find('"', at + 10);
      if (at == std::string::npos || at + 17 > header.size()) break;
      ++at;
      if (!a.is_object() || !a.contains("offset") || !a.contains("bytes") ||
          !a["offset"].is_number_unsigned() || !a["bytes"].is_number_unsigned())
        continue;
      const uint64_t off = a["offset"], n = a["bytes"];
      if (off > b.size() || n > b.size() - off) continue;
      const std::string sum = hex64(checksum64(b.data() + off, n));
      if (header.compare(at, 16, sum) != 0 && std::isxdigit(static_cast<unsigned char>(header[at])))
        header.replace(at, 16, sum);
    }
    b.replace(container::kPreambleBytes, header.size(), header);
  }
  if (!j.is_discarded() && j.is_object() && j.contains("vmf") && j["vmf"].is_object()) {
    // The visibility map's block (written before "arrays" in the header), patched likewise.
    const auto& v = j["vmf"];
    size_t at = header.find("\"vmf\"");
    if (at != std::string::npos) at = header.find("\"checksum\"", at);
    if (at != std::string::npos) at = header.find('"', at + 10);
    if (at != std::string::npos && at + 17 <= header.size() && v.contains("offset") &&
        v.contains("bytes") && v["offset"].is_number_unsigned() && v["bytes"].is_number_unsigned()) {
      ++at;
      const uint64_t off = v["offset"], n = v["bytes"];
      if (off <= b.size() && n <= b.size() - off &&
          std::isxdigit(static_cast<unsigned char>(header[at])))
        header.replace(at, 16, hex64(checksum64(b.data() + off, n)));
      b.replace(container::kPreambleBytes, header.size(), header);
    }
  }
  put64(b, 16, checksum64(header));
}

}  // namespace

void checkDecoder(const Decoder& d) {
  const BtfInfo& in = d.info();
  const int n = in.nDirs();
  check(n > 0 && in.texels() > 0, "a BTF without directions or texels was accepted");
  std::vector<float> t(size_t(n) * n * 3);
  for (int64_t texel : {int64_t(0), in.texels() - 1}) {
    d.texel(texel, t.data());
    for (float v : t) check(std::isfinite(v) && v >= 0, "a decoded value not finite or < 0");
    const auto v = d.value(texel, n - 1, 0);
    for (float c : v) check(std::isfinite(c) && c >= 0, "a value not finite or < 0");
  }
  const auto e = d.evaluateAt(0.37, 0.61, 0.4, 1.0, 0.8, 2.5);
  for (float c : e) check(std::isfinite(c) && c >= 0, "an interpolated value not finite or < 0");
}

std::string writeRepaired(const uint8_t* data, size_t size, const std::string& ext) {
  const std::string b = repairChecksums(std::string(reinterpret_cast<const char*>(data), size));
  return writeInput(reinterpret_cast<const uint8_t*>(b.data()), b.size(), ext);
}

void runCliReaders(const std::string& path) {
  RunContext ctx;
  ctx.threads = 1;
  ctx.progress = false;
  ops::Request info("info");
  info.set("btf", path);
  ops::run(info, ctx);
  // The other readers of a BTF as the CLI runs them: a hemisphere slice of the texel average
  // (every texel, every view) and a comparison with itself (every value, twice).
  ops::Request slice("slice");
  slice.set("btf", path).set("output", inputDir() + "/slice.exr");
  slice.set("texel", "avg").set("light", "30,0").set("size", 8);
  ops::run(slice, ctx);
  ops::Request compare("compare");
  compare.set("a", path).set("b", path);
  const ops::Report same = ops::run(compare, ctx);
  check(same.json.contains("rmse") && same.json["rmse"].get<double>() == 0 &&
            same.json["max_abs_error"].get<double>() == 0,
        "a BTF compared with itself has a nonzero error");
}

std::string repairChecksums(std::string b) {
  if (b.size() < 8) return b;
  if (std::memcmp(b.data(), "BTFSTOR1", 8) == 0)
    repairBtf(b);
  else if (std::memcmp(b.data(), "BTFCOMP1", 8) == 0)
    repairCbtf(b);
  return b;
}

}  // namespace btf::fuzz
