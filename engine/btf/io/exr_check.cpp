#include <btf/core/error.h>
#include <btf/io/exr_check.h>

#include <cstring>

namespace btf {

void checkExrHeader(const std::string& path, const std::string& b, uint64_t maxPixels) {
  auto fail = [&](const std::string& what) -> void {
    throw Error(path + ": malformed OpenEXR header: " + what);
  };
  // OpenEXR reads the values of the types it knows by their own layout, not by the declared
  // size: a size that disagrees with the layout shifts every attribute after it (and a shifted
  // string size is a gigabyte allocation). Each known type's value must fill its size exactly.
  auto checkValue = [&](const std::string& attr, const std::string& type, const char* v, size_t n) {
    static const std::pair<const char*, size_t> fixed[] = {{"box2i", 16},
                                                           {"box2f", 16},
                                                           {"compression", 1},
                                                           {"lineOrder", 1},
                                                           {"envmap", 1},
                                                           {"deepImageState", 1},
                                                           {"chromaticities", 32},
                                                           {"double", 8},
                                                           {"float", 4},
                                                           {"int", 4},
                                                           {"keycode", 28},
                                                           {"m33f", 36},
                                                           {"m33d", 72},
                                                           {"m44f", 64},
                                                           {"m44d", 128},
                                                           {"rational", 8},
                                                           {"tiledesc", 9},
                                                           {"timecode", 8},
                                                           {"v2i", 8},
                                                           {"v2f", 8},
                                                           {"v2d", 16},
                                                           {"v3i", 12},
                                                           {"v3f", 12},
                                                           {"v3d", 24}};
    for (const auto& [t, size] : fixed)
      if (type == t && n != size)
        fail("attribute '" + attr + "' of type " + type + " has " + std::to_string(n) +
             " bytes, not " + std::to_string(size));
    auto i32 = [&](size_t at) {
      int32_t x;
      std::memcpy(&x, v + at, 4);
      return x;
    };
    if (type == "chlist") {
      // (name\0, pixel type i32, pLinear u8, 3 reserved, xSampling i32, ySampling i32)*, \0
      size_t q = 0;
      int channels = 0;
      while (true) {
        if (q >= n) fail("channel list of '" + attr + "' runs past its size");
        if (v[q] == '\0') {
          ++q;
          break;
        }
        const void* z = std::memchr(v + q, '\0', std::min<size_t>(n - q, 256));
        if (!z) fail("a channel name in '" + attr + "' runs past its size or 255 characters");
        q = size_t(static_cast<const char*>(z) - v) + 1;
        if (q + 16 > n) fail("channel list of '" + attr + "' runs past its size");
        if (i32(q) < 0 || i32(q) > 2) fail("a channel of '" + attr + "' has an unknown type");
        if (i32(q + 8) < 1 || i32(q + 12) < 1) fail("a channel sampling is not positive");
        q += 16;
        if (++channels > 1024) fail("more than 1024 channels");
      }
      if (q != n) fail("channel list of '" + attr + "' does not fill its size");
    } else if (type == "stringvector") {
      size_t q = 0;
      while (q < n) {
        if (q + 4 > n || i32(q) < 0 || size_t(i32(q)) > n - q - 4)
          fail("string vector '" + attr + "' runs past its size");
        q += 4 + size_t(i32(q));
      }
    } else if (type == "preview") {
      if (n < 8) fail("preview '" + attr + "' is shorter than its size fields");
      uint32_t w, h;
      std::memcpy(&w, v, 4);
      std::memcpy(&h, v + 4, 4);
      if (uint64_t(w) * uint64_t(h) * 4 + 8 != n)
        fail("preview '" + attr + "' of " + std::to_string(w) + " × " + std::to_string(h) +
             " pixels does not fill its " + std::to_string(n) + " bytes");
    } else if (type == "floatvector" && n % 4 != 0) {
      fail("float vector '" + attr + "' is not a whole number of floats");
    }
  };
  if (b.size() < 8) fail("shorter than its 8-byte preamble");
  uint32_t magic, version;
  std::memcpy(&magic, b.data(), 4);
  std::memcpy(&version, b.data() + 4, 4);
  if (magic != 20000630u) fail("bad magic number (not an OpenEXR file)");
  if ((version & 0xff) != 2) fail("unsupported version " + std::to_string(version & 0xff));
  const bool longNames = version & 0x400, multipart = version & 0x1000;
  const size_t maxName = longNames ? 255 : 31;
  size_t p = 8;
  // A null-terminated string of at most maxName characters at p.
  auto name = [&](const std::string& what) {
    const size_t end = b.find('\0', p);
    if (end == std::string::npos) fail(what + " runs past the end of the file");
    if (end - p > maxName) fail(what + " longer than " + std::to_string(maxName) + " characters");
    // Printable for messages: a damaged name is shown, not sent to the terminal raw.
    std::string s;
    for (size_t i = p; i < end; ++i) {
      const unsigned char c = static_cast<unsigned char>(b[i]);
      s += c >= 32 && c < 127 ? char(c) : '?';
    }
    p = end + 1;
    return s;
  };
  for (int part = 0;; ++part) {
    if (p >= b.size()) fail("header " + std::to_string(part) + " runs past the end of the file");
    if (b[p] == '\0') {  // an empty header: the end of a multi-part file's header list
      if (part == 0) fail("no attributes");
      break;
    }
    bool window = false;
    while (true) {
      if (p >= b.size()) fail("attribute list runs past the end of the file");
      if (b[p] == '\0') {
        ++p;
        break;
      }
      const std::string attr = name("attribute name");
      const std::string type = name("attribute type of '" + attr + "'");
      if (p + 4 > b.size()) fail("attribute '" + attr + "' has no size");
      int32_t size;
      std::memcpy(&size, b.data() + p, 4);
      p += 4;
      if (size < 0 || uint64_t(size) > b.size() - p)
        fail("attribute '" + attr + "' declares " + std::to_string(size) +
             " bytes, more than the file holds");
      checkValue(attr, type, b.data() + p, size_t(size));
      if (attr == "dataWindow") {
        if (type != "box2i" || size != 16) fail("dataWindow must be a box2i of 16 bytes");
        int32_t w[4];
        std::memcpy(w, b.data() + p, 16);
        const int64_t width = int64_t(w[2]) - w[0] + 1, height = int64_t(w[3]) - w[1] + 1;
        if (width < 1 || height < 1) fail("empty dataWindow");
        if (width > 65536 || height > 65536 || uint64_t(width) * uint64_t(height) > maxPixels)
          fail("dataWindow of " + std::to_string(width) + " × " + std::to_string(height) +
               " pixels is larger than the " + std::to_string(maxPixels) +
               " pixels the memory budget allows");
        window = true;
      }
      p += size_t(size);
    }
    if (!window) fail("header " + std::to_string(part) + " has no dataWindow");
    if (!multipart) break;
    if (part > 64) fail("more than 64 parts");
  }
}

}  // namespace btf
