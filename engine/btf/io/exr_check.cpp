#include <btf/core/error.h>
#include <btf/io/exr_check.h>

#include <cstring>

namespace btf {

void checkExrHeader(const std::string& path, const std::string& b, uint64_t maxPixels) {
  auto fail = [&](const std::string& what) -> void {
    throw Error(path + ": malformed OpenEXR header: " + what);
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
