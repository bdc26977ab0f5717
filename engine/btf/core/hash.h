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

}  // namespace btf
