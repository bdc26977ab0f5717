// Counter-based random numbers: a value depends only on (seed, keys), never on thread
// scheduling, so a run is reproducible with any thread count and resumable mid-way.
#pragma once
#include <cstdint>

namespace btf {

inline uint64_t mix64(uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

inline uint64_t hashKeys(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0) {
  return mix64(mix64(mix64(seed ^ mix64(a)) ^ b) ^ c);
}

/// Uniform float in [0, 1) from 64 random bits (24 mantissa bits, never 1).
inline float uniformFloat(uint64_t bits) {
  return float(bits >> 40) * (1.0f / 16777216.0f);
}

/// A small sequential generator (splitmix64) for streams that are seeded per task.
class Rng {
 public:
  explicit Rng(uint64_t seed) : m_state(seed) {}
  uint64_t next() {
    m_state += 0x9e3779b97f4a7c15ull;
    return mix64(m_state);
  }
  float uniform() { return uniformFloat(next()); }
  double uniformDouble() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }

 private:
  uint64_t m_state;
};

}  // namespace btf
