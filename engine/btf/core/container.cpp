#include <btf/core/container.h>
#include <btf/core/error.h>
#include <btf/core/hash.h>

#include <cstring>
#include <filesystem>
#include <fstream>

namespace btf::container {

std::array<char, kPreambleBytes> preamble(const Magic& magic, const std::string& header) {
  std::array<char, kPreambleBytes> p{};
  const uint64_t len = header.size(), sum = checksum64(header);
  std::memcpy(p.data(), magic.data(), 8);
  std::memcpy(p.data() + 8, &len, 8);
  std::memcpy(p.data() + 16, &sum, 8);
  return p;
}

Preamble parsePreamble(const char* first24, uint64_t fileBytes, const Magic& magic,
                       const std::string& path, const std::string& kind) {
  if (fileBytes < kPreambleBytes)
    throw Error(path + ": truncated file: not a " + kind + " (shorter than its 24-byte preamble)");
  if (std::memcmp(first24, magic.data(), 8) != 0)
    throw Error(path + ": not a " + kind + " (bad magic bytes)");
  Preamble p;
  std::memcpy(&p.headerBytes, first24 + 8, 8);
  std::memcpy(&p.checksum, first24 + 16, 8);
  if (p.headerBytes > fileBytes - kPreambleBytes)
    throw Error(path + ": truncated file (the header runs past the end)");
  if (p.headerBytes > kMaxHeaderBytes)
    throw Error(path + ": corrupt header length " + std::to_string(p.headerBytes) +
                " bytes (at most " + std::to_string(kMaxHeaderBytes) + ")");
  return p;
}

void checkHeader(const std::string& header, const Preamble& p, const std::string& path) {
  if (header.size() != p.headerBytes || checksum64(header) != p.checksum)
    throw Error(path + ": header checksum mismatch (corrupt file)");
}

bool hasMagic(const std::string& path, const Magic& magic) {
  // Only regular files are opened (a fifo would block); the readers then name what is wrong.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream f(path, std::ios::binary);
  char m[8] = {};
  f.read(m, 8);
  return f.gcount() == 8 && std::memcmp(m, magic.data(), 8) == 0;
}

}  // namespace btf::container
