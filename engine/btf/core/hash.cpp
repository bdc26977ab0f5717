#include <btf/core/hash.h>
#include <btf/core/rng.h>

#include <algorithm>
#include <cstdio>
#include <cstring>

namespace btf {

namespace {

void lanes(uint64_t h[4], const unsigned char* p) {
  for (int k = 0; k < 4; ++k) {
    uint64_t w;
    std::memcpy(&w, p + 8 * k, 8);
    h[k] = (h[k] ^ w) * 0x9e3779b97f4a7c15ull;
    h[k] ^= h[k] >> 29;
  }
}

uint64_t fold(const uint64_t h[4], const unsigned char* tail, size_t tailBytes, size_t total) {
  uint64_t r = mix64(h[0]) ^ mix64(h[1] + 1) ^ mix64(h[2] + 2) ^ mix64(h[3] + 3);
  for (size_t i = 0; i < tailBytes; ++i) r = (r ^ tail[i]) * 0x100000001b3ull;
  return mix64(r ^ total);
}

}  // namespace

// Four independent lanes so the multiply chains overlap; folded at the end.
Checksum64::Checksum64(uint64_t seed)
    : m_h{seed ^ 0x243f6a8885a308d3ull, seed ^ 0x13198a2e03707344ull, seed ^ 0xa4093822299f31d0ull,
          seed ^ 0x082efa98ec4e6c89ull} {}

void Checksum64::update(const void* data, size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  m_total += bytes;
  if (bytes == 0) return;
  if (m_tailBytes) {
    const size_t take = std::min(bytes, 32 - m_tailBytes);
    std::memcpy(m_tail + m_tailBytes, p, take);
    m_tailBytes += take;
    p += take;
    bytes -= take;
    if (m_tailBytes < 32) return;
    lanes(m_h, m_tail);
    m_tailBytes = 0;
  }
  for (; bytes >= 32; p += 32, bytes -= 32) lanes(m_h, p);
  if (bytes) std::memcpy(m_tail, p, bytes);  // (p may be null when nothing is left)
  m_tailBytes = bytes;
}

uint64_t Checksum64::finish() const {
  return fold(m_h, m_tail, m_tailBytes, m_total);
}

uint64_t checksum64(const void* data, size_t bytes, uint64_t seed) {
  Checksum64 c(seed);
  c.update(data, bytes);
  return c.finish();
}

std::string hex64(uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

}  // namespace btf
