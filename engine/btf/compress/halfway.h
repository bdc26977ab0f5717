// Half-vector reparameterisation of a texel's aBRDF (Kautz & McCool 1999; Lawrence et al. 2004;
// docs/compression.md "Half-vector reparameterisation"): each view's light slice f(v, ·) is
// resampled at half vectors h_j — the set's own directions read as half vectors — so that a
// specular lobe around the mirror direction lands on the same columns for every view:
//   forward   R(v, j) = f(v, l_vj),     l_vj = 2 (v·h_j) h_j − v   (light-set interpolation)
//   inverse   f'(v, l) = R(v, h(v, l)), h(v, l) = (v + l) / |v + l|  (half-set interpolation)
// Both are the set's ring-linear interpolation (DirectionSet::interpolate: weights ≥ 0 summing to
// one), so a constant slice comes back exactly and a lobe that is a function of h alone comes
// back with the interpolation error of the set. A mirror direction below the horizon takes the
// horizon's value (clamped to the last ring), as the interpolation does beyond the set.
#pragma once
#include <btf/directions/direction_set.h>

#include <cstdint>
#include <vector>

namespace btf {

class HalfwayMap {
 public:
  explicit HalfwayMap(const DirectionSet& set);
  int size() const { return m_n; }
  /// One texel's values, out[(v·n + j)·channels + c] = R(v, j) from in[(v·n + l)·channels + c].
  void forward(const float* in, float* out, int channels = 3) const;
  /// The inverse resampling: out[(v·n + l)·channels + c] = f'(v, l).
  void inverse(const float* in, float* out, int channels = 3) const;
  /// The (up to four) half-set columns and weights that f'(v, l) reads.
  int inverseTaps(int view, int light, DirWeight out[4]) const;

 private:
  struct Taps {
    uint16_t index[4];
    float weight[4];
    int count;
  };
  static void apply(const std::vector<Taps>& taps, int n, const float* in, float* out,
                    int channels);
  int m_n = 0;
  std::vector<Taps> m_forward, m_inverse;  // per (view, column)
};

}  // namespace btf
