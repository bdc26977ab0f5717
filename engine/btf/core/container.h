// The container layout both BTF files share (docs/store-format.md, docs/compression.md): an
// 8-byte magic, the header JSON's length and checksum (u64 little-endian each), the header,
// then sections aligned to 64 bytes or more. One writer and one checked reader of that preamble
// for the raw store (.btf) and the compressed file (.cbtf).
#pragma once
#include <array>
#include <cstdint>
#include <string>

namespace btf::container {

constexpr uint64_t kPreambleBytes = 24;
/// Headers are JSON of settings and tables: anything larger is a damaged or hostile file.
constexpr uint64_t kMaxHeaderBytes = uint64_t(256) << 20;

inline uint64_t alignUp(uint64_t x, uint64_t a) {
  return (x + a - 1) / a * a;
}

using Magic = std::array<char, 8>;

/// The 24 bytes that precede `header`.
std::array<char, kPreambleBytes> preamble(const Magic& magic, const std::string& header);

struct Preamble {
  uint64_t headerBytes = 0, checksum = 0;
};
/// Checks the first 24 bytes of a file of `fileBytes` bytes: the magic (else "PATH: not a
/// KIND (bad magic bytes)"), a header length within the file and kMaxHeaderBytes — before
/// anything is allocated from it.
Preamble parsePreamble(const char* first24, uint64_t fileBytes, const Magic& magic,
                       const std::string& path, const std::string& kind);
/// The header read after the preamble matches its checksum (else "header checksum mismatch").
void checkHeader(const std::string& header, const Preamble& p, const std::string& path);
/// True when the file starts with `magic`.
bool hasMagic(const std::string& path, const Magic& magic);

}  // namespace btf::container
