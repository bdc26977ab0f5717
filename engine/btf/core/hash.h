// Checksums for stored data (chunks, headers, scene identity). Not cryptographic: it detects
// flipped bytes and truncation, and it is fast (8 bytes per step).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace btf {

uint64_t checksum64(const void* data, size_t bytes, uint64_t seed = 0);
inline uint64_t checksum64(std::string_view s, uint64_t seed = 0) {
  return checksum64(s.data(), s.size(), seed);
}
std::string hex64(uint64_t v);

/// checksum64 over data given in pieces (a chunk verified while it streams from disk): the same
/// value as one call over the concatenation.
class Checksum64 {
 public:
  explicit Checksum64(uint64_t seed = 0);
  void update(const void* data, size_t bytes);
  uint64_t finish() const;

 private:
  uint64_t m_h[4];
  unsigned char m_tail[32];
  size_t m_tailBytes = 0, m_total = 0;
};

}  // namespace btf
