#include "cbtf.h"

#include <btf/core/container.h>
#include <btf/core/error.h>
#include <btf/core/format.h>
#include <btf/core/hash.h>
#include <btf/core/input_file.h>
#include <btf/core/json_limits.h>
#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "linalg.h"

namespace btf {
namespace {

constexpr container::Magic kMagic = {'B', 'T', 'F', 'C', 'O', 'M', 'P', '1'};
constexpr int kFormatVersion = 1;
using container::alignUp;

const char* typeName(ArrayType t) {
  return t == ArrayType::F16 ? "f16" : "f32";
}

std::vector<uint8_t> encodeArray(const CArray& a) {
  std::vector<uint8_t> out(a.storedBytes());
  if (a.type == ArrayType::F16) {
    for (size_t i = 0; i < a.data.size(); ++i) {
      const uint16_t h = la::floatToHalf(a.data[i]);
      std::memcpy(&out[2 * i], &h, 2);
    }
  } else {
    for (size_t i = 0; i < a.data.size(); ++i) {
      const float f = std::isfinite(a.data[i]) ? a.data[i] : 0.f;
      std::memcpy(&out[4 * i], &f, 4);
    }
  }
  return out;
}

struct Layout {
  std::string header;
  std::vector<uint64_t> offsets;
  uint64_t total = 0;
};

Layout layoutOf(const CompressedBtf& c, const std::vector<std::vector<uint8_t>>& bytes) {
  // Offsets depend on the header length, which contains them: iterate to a fixed point (the
  // header only grows by digits, so two or three passes settle it).
  Layout L;
  L.offsets.assign(bytes.size(), 0);
  for (int pass = 0; pass < 8; ++pass) {
    nlohmann::ordered_json j;
    j["format"] = "btfstudio-compressed-btf";
    j["format_version"] = kFormatVersion;
    j["codec"] = c.codec;
    j["colour"] = c.colour;
    j["params"] = nlohmann::ordered_json::parse(c.paramsJson);
    j["stats"] = nlohmann::ordered_json::parse(c.statsJson);
    j["source"] = nlohmann::ordered_json::parse(infoToJson(c.info));
    if (!c.levels.empty()) {
      nlohmann::ordered_json lv = nlohmann::ordered_json::array();
      for (const MipLevel& l : c.levels)
        lv.push_back({{"texels", {l.nu, l.nv}}, {"first", l.first}});
      j["levels"] = lv;
    }
    nlohmann::ordered_json arr = nlohmann::ordered_json::array();
    if (c.hasVmf()) {
      const size_t i = c.arrays.size();  // the map's block follows the arrays
      j["vmf"] = {{"coder", "u8-planes-deflate"},
                  {"directions", c.info.nDirs()},
                  {"texels", {c.info.nu, c.info.nv}},
                  {"depth_range", {c.vmfDepth[0], c.vmfDepth[1]}},
                  {"offset", L.offsets[i]},
                  {"bytes", bytes[i].size()},
                  {"checksum", hex64(checksum64(bytes[i].data(), bytes[i].size()))}};
    }
    for (size_t i = 0; i < c.arrays.size(); ++i) {
      const CArray& a = c.arrays[i];
      nlohmann::ordered_json e;
      e["name"] = a.name;
      e["type"] = typeName(a.type);
      e["rows"] = a.rows;
      e["cols"] = a.cols;
      e["offset"] = L.offsets[i];
      e["bytes"] = a.storedBytes();
      e["checksum"] = hex64(checksum64(bytes[i].data(), bytes[i].size()));
      arr.push_back(e);
    }
    j["arrays"] = arr;
    const std::string header = j.dump(1);
    uint64_t off = alignUp(24 + header.size(), 64);
    std::vector<uint64_t> offsets;
    for (const auto& b : bytes) {
      offsets.push_back(off);
      off = alignUp(off + b.size(), 64);
    }
    const uint64_t total = bytes.empty() ? 24 + header.size() : offsets.back() + bytes.back().size();
    if (offsets == L.offsets && header == L.header) break;
    L.offsets = offsets;
    L.header = header;
    L.total = total;
  }
  return L;
}

}  // namespace

const CArray& CompressedBtf::array(const std::string& name) const {
  for (const auto& a : arrays)
    if (a.name == name) return a;
  throw Error("compressed BTF (" + codec + "): missing array '" + name + "'");
}

bool CompressedBtf::hasArray(const std::string& name) const {
  for (const auto& a : arrays)
    if (a.name == name) return true;
  return false;
}

CArray& CompressedBtf::add(std::string name, ArrayType type, int64_t rows, int64_t cols) {
  CArray a;
  a.name = std::move(name);
  a.type = type;
  a.rows = rows;
  a.cols = cols;
  a.data.assign(size_t(rows * cols), 0.f);
  arrays.push_back(std::move(a));
  return arrays.back();
}

void CompressedBtf::quantize() {
  for (auto& a : arrays)
    for (float& v : a.data) {
      if (!std::isfinite(v)) v = 0.f;
      if (a.type == ArrayType::F16) v = la::halfToFloat(la::floatToHalf(v));
    }
}

uint64_t CompressedBtf::payloadBytes() const {
  uint64_t s = 0;
  for (const auto& a : arrays) s += a.storedBytes();
  return s;
}

uint64_t CompressedBtf::fileBytes() const {
  std::vector<std::vector<uint8_t>> bytes;
  for (const auto& a : arrays) bytes.emplace_back(a.storedBytes());  // sizes only matter
  if (hasVmf()) bytes.push_back(vmfCoded);
  return layoutOf(*this, bytes).total;
}

void CompressedBtf::setVmf(const std::vector<float>& vmf) {
  vmfCoded.clear();
  vmfDepth[0] = vmfDepth[1] = 0;
  if (vmf.empty()) return;
  const size_t n = vmf.size() / 2;
  if (vmf.size() != size_t(info.nDirs()) * size_t(info.texels()) * 2)
    throw Error(format("visibility map of %zu values for %d directions × %lld texels", vmf.size(),
                       info.nDirs(), (long long)info.texels()));
  float lo = 0, hi = 0;
  bool any = false;
  for (size_t k = 0; k < n; ++k) {
    const float d = vmf[2 * k + 1];
    if (!std::isfinite(d)) continue;
    lo = any ? std::min(lo, d) : d;
    hi = any ? std::max(hi, d) : d;
    any = true;
  }
  // Two planes (coverage, then depth) of 8-bit codes: each plane is smooth over directions and
  // texels, which deflate exploits; a depth is lo + q/255·(hi − lo), off by ≤ (hi − lo)/510.
  std::vector<uint8_t> planes(2 * n);
  for (size_t k = 0; k < n; ++k) {
    const float c = vmf[2 * k], d = vmf[2 * k + 1];
    planes[k] = uint8_t(std::lround(255.0 * std::clamp(std::isfinite(c) ? double(c) : 0.0, 0.0, 1.0)));
    const double f = hi > lo && std::isfinite(d) ? (double(d) - lo) / (double(hi) - lo) : 0.0;
    planes[n + k] = uint8_t(std::lround(255.0 * std::clamp(f, 0.0, 1.0)));
  }
  uLongf len = compressBound(uLong(planes.size()));
  vmfCoded.resize(len);
  if (compress2(vmfCoded.data(), &len, planes.data(), uLong(planes.size()), 9) != Z_OK)
    throw Error("visibility map: deflate failed");
  vmfCoded.resize(len);
  vmfDepth[0] = lo, vmfDepth[1] = hi;
}

std::vector<float> CompressedBtf::vmf() const {
  if (vmfCoded.empty()) return {};
  const std::string where = (source.empty() ? std::string("compressed BTF") : source) + ": vmf";
  const uint64_t n = uint64_t(info.nDirs()) * uint64_t(info.texels());
  // Deflate's best ratio is about 1032:1: a larger claim is a damaged header, not a map.
  if (2 * n > 1100 * uint64_t(vmfCoded.size()) + 4096)
    throw Error(format("%s: %llu coded bytes cannot hold %d directions × %lld texels", where.c_str(),
                       (unsigned long long)vmfCoded.size(), info.nDirs(),
                       (long long)info.texels()));
  std::vector<uint8_t> planes(size_t(2 * n));
  uLongf len = uLongf(planes.size());
  if (uncompress(planes.data(), &len, vmfCoded.data(), uLong(vmfCoded.size())) != Z_OK ||
      len != planes.size())
    throw Error(where + ": the coded map does not inflate to its " + std::to_string(2 * n) +
                " bytes (corrupt)");
  std::vector<float> out(size_t(2 * n));
  const double lo = vmfDepth[0], step = (double(vmfDepth[1]) - lo) / 255.0;
  for (size_t k = 0; k < size_t(n); ++k) {
    out[2 * k] = float(planes[k] / 255.0);
    out[2 * k + 1] = float(lo + step * planes[size_t(n) + k]);
  }
  return out;
}

double CompressedBtf::ratio() const {
  const double raw = double(info.texels()) * double(info.nDirs()) * info.nDirs() * 12.0;
  return raw / double(std::max<uint64_t>(1, fileBytes()));
}

void writeCompressed(const std::string& path, const CompressedBtf& c) {
  std::vector<std::vector<uint8_t>> bytes;
  for (const auto& a : c.arrays) {
    if (int64_t(a.data.size()) != a.rows * a.cols)
      throw Error("compressed BTF: array '" + a.name + "' has the wrong size");
    bytes.push_back(encodeArray(a));
  }
  if (c.hasVmf()) bytes.push_back(c.vmfCoded);
  const Layout L = layoutOf(c, bytes);
  const std::string partial = path + ".partial";
  const int fd = ::open(partial.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) throw Error(partial + ": cannot create (" + std::strerror(errno) + ")");
  auto put = [&](const void* data, uint64_t n, uint64_t off) {
    const char* p = static_cast<const char*>(data);
    while (n > 0) {
      const ssize_t w = ::pwrite(fd, p, n, off_t(off));
      if (w <= 0) {
        const std::string why = std::strerror(errno);
        ::close(fd);
        std::filesystem::remove(partial);
        throw Error(partial + ": write failed (" + why + ")");
      }
      p += w;
      n -= uint64_t(w);
      off += uint64_t(w);
    }
  };
  const uint64_t hlen = L.header.size();
  const auto pre = container::preamble(kMagic, L.header);
  put(pre.data(), pre.size(), 0);
  put(L.header.data(), hlen, 24);
  const std::vector<char> zeros(64, 0);
  uint64_t end = 24 + hlen;
  for (size_t i = 0; i < bytes.size(); ++i) {
    if (L.offsets[i] > end) put(zeros.data(), L.offsets[i] - end, end);
    put(bytes[i].data(), bytes[i].size(), L.offsets[i]);
    end = L.offsets[i] + bytes[i].size();
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    std::filesystem::remove(partial);
    throw Error(partial + ": fsync/close failed");
  }
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (ec) throw Error(path + ": cannot rename the finished file into place (" + ec.message() + ")");
}

bool isCompressedFile(const std::string& path) {
  return container::hasMagic(path, kMagic);
}

CompressedBtf readCompressed(const std::string& path) {
  checkInputFile(path, "compressed BTF");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open");
  f.seekg(0, std::ios::end);
  const uint64_t size = uint64_t(f.tellg());
  f.seekg(0);
  char first[container::kPreambleBytes] = {};
  f.read(first, sizeof first);
  const container::Preamble pre =
      container::parsePreamble(first, f ? size : 0, kMagic, path, "compressed BTF");
  const uint64_t hlen = pre.headerBytes;
  std::string header(hlen, '\0');
  f.read(header.data(), std::streamsize(hlen));
  container::checkHeader(header, pre, path);
  CompressedBtf c;
  c.source = path;
  nlohmann::json j;
  checkJsonDepth(header, path + " (header)");
  try {
    j = nlohmann::json::parse(header);
  } catch (const nlohmann::json::exception&) {
    throw Error(path + ": malformed compressed-BTF header (not valid JSON)");
  }
  if (!j.is_object()) throw Error(path + ": malformed compressed-BTF header (not a JSON object)");
  const JsonFields h(j, path);
  if (h.string("/format") != "btfstudio-compressed-btf")
    throw Error(path + ": not a compressed BTF header");
  if (h.integer("/format_version", 0, 1 << 30) != kFormatVersion)
    throw Error(path + ": unsupported compressed-BTF version " + j.at("format_version").dump());
  c.codec = h.string("/codec");
  c.colour = h.string("/colour");
  if (!h.at("/params").is_object()) h.fail("/params", "must be an object");
  if (!h.at("/stats").is_object()) h.fail("/stats", "must be an object");
  c.paramsJson = j.at("params").dump();
  c.statsJson = j.at("stats").dump();
  c.info = infoFromJson(h.at("/source").dump(), path);
  if (j.contains("levels")) {
    // A pyramid: its levels follow from the texel grid; the header lists them for readers.
    const auto& lv = h.at("/levels");
    const std::vector<MipLevel> want = mipLevels(c.info.nu, c.info.nv);
    if (!lv.is_array() || lv.size() != want.size())
      h.fail("/levels", "must list the " + std::to_string(want.size()) + " levels of a " +
                            std::to_string(c.info.nu) + "×" + std::to_string(c.info.nv) +
                            " texel grid");
    for (size_t k = 0; k < want.size(); ++k) {
      const std::string p = "/levels/" + std::to_string(k);
      const MipLevel got{int(h.integer(p + "/texels/0", 1, 1 << 30)),
                         int(h.integer(p + "/texels/1", 1, 1 << 30)),
                         h.integer(p + "/first", 0, int64_t(1) << 50)};
      if (!(got == want[k]))
        h.fail(p, format("must be %d×%d texels from texel %lld", want[k].nu, want[k].nv,
                         (long long)want[k].first));
    }
    c.levels = want;
  }
  uint64_t end = 24 + hlen;
  const auto& list = h.at("/arrays");
  if (!list.is_array()) h.fail("/arrays", "must be a list");
  for (size_t k = 0; k < list.size(); ++k) {
    // Every size is checked against the file before anything is allocated from it.
    const std::string p = "/arrays/" + std::to_string(k);
    CArray a;
    a.name = h.string(p + "/name");
    const std::string type = h.string(p + "/type");
    if (type != "f16" && type != "f32")
      throw Error(path + ": array '" + a.name + "' has unknown type '" + type + "'");
    a.type = type == "f16" ? ArrayType::F16 : ArrayType::F32;
    const int64_t maxCount = int64_t(size);  // no array has more elements than the file bytes
    a.rows = h.integer(p + "/rows", 0, maxCount);
    a.cols = h.integer(p + "/cols", 0, maxCount);
    uint64_t elems = 0;
    if (__builtin_mul_overflow(uint64_t(a.rows), uint64_t(a.cols), &elems) ||
        elems > uint64_t(size))
      throw Error(path + ": array '" + a.name + "': " + std::to_string(a.rows) + " × " +
                  std::to_string(a.cols) + " elements cannot fit in a " + std::to_string(size) +
                  "-byte file");
    const uint64_t off = uint64_t(h.integer(p + "/offset", 0, maxCount));
    const uint64_t bytes = uint64_t(h.integer(p + "/bytes", 0, maxCount));
    if (bytes != a.storedBytes())
      throw Error(path + ": array '" + a.name + "' has inconsistent dimensions");
    if (bytes > size || off > size - bytes)
      throw Error(path + ": truncated file (array '" + a.name + "' ends at byte " +
                  std::to_string(off + bytes) + ", the file has " + std::to_string(size) + ")");
    std::vector<uint8_t> raw(bytes);
    f.seekg(std::streamoff(off));
    f.read(reinterpret_cast<char*>(raw.data()), std::streamsize(bytes));
    if (!f) throw Error(path + ": read error in array '" + a.name + "'");
    if (hex64(checksum64(raw.data(), raw.size())) != h.string(p + "/checksum"))
      throw Error(path + ": checksum mismatch in array '" + a.name + "' (corrupt file)");
    a.data.resize(size_t(a.rows * a.cols));
    for (size_t i = 0; i < a.data.size(); ++i) {
      if (a.type == ArrayType::F16) {
        uint16_t h;
        std::memcpy(&h, &raw[2 * i], 2);
        a.data[i] = la::halfToFloat(h);
      } else {
        std::memcpy(&a.data[i], &raw[4 * i], 4);
      }
    }
    end = std::max(end, off + bytes);
    c.arrays.push_back(std::move(a));
  }
  if (j.contains("vmf")) {
    // The visibility map: its grid must be the file's level 0; decoded once here to validate.
    if (h.string("/vmf/coder") != "u8-planes-deflate")
      h.fail("/vmf/coder", "must be u8-planes-deflate");
    if (h.integer("/vmf/directions", 0, 1 << 30) != c.info.nDirs())
      h.fail("/vmf/directions", "must be the file's " + std::to_string(c.info.nDirs()));
    if (h.integer("/vmf/texels/0", 0, 1 << 30) != c.info.nu ||
        h.integer("/vmf/texels/1", 0, 1 << 30) != c.info.nv)
      h.fail("/vmf/texels", format("must be the file's %d×%d", c.info.nu, c.info.nv));
    const auto& range = h.at("/vmf/depth_range");
    if (!range.is_array() || range.size() != 2 || !range[0].is_number() || !range[1].is_number())
      h.fail("/vmf/depth_range", "must be two numbers");
    c.vmfDepth[0] = range[0].get<float>(), c.vmfDepth[1] = range[1].get<float>();
    if (!std::isfinite(c.vmfDepth[0]) || !std::isfinite(c.vmfDepth[1]) ||
        c.vmfDepth[1] < c.vmfDepth[0])
      h.fail("/vmf/depth_range", "must be finite, low ≤ high");
    const uint64_t off = uint64_t(h.integer("/vmf/offset", 0, int64_t(size)));
    const uint64_t bytes = uint64_t(h.integer("/vmf/bytes", 1, int64_t(size)));
    if (bytes > size || off > size - bytes)
      throw Error(path + ": truncated file (the visibility map ends at byte " +
                  std::to_string(off + bytes) + ", the file has " + std::to_string(size) + ")");
    c.vmfCoded.resize(bytes);
    f.seekg(std::streamoff(off));
    f.read(reinterpret_cast<char*>(c.vmfCoded.data()), std::streamsize(bytes));
    if (!f) throw Error(path + ": read error in the visibility map");
    if (hex64(checksum64(c.vmfCoded.data(), bytes)) != h.string("/vmf/checksum"))
      throw Error(path + ": checksum mismatch in the visibility map (corrupt file)");
    (void)c.vmf();
    end = std::max(end, off + bytes);
  }
  if (end != size)
    throw Error(path + ": file has " + std::to_string(size - end) +
                " trailing bytes after the last array (corrupt or concatenated)");
  return c;
}

}  // namespace btf
