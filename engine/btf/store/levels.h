// Texel levels of a multi-resolution BTF (docs/mip.md; thesis §4.4): level 0 is the simulated
// grid; level k+1 is the box average of level k over boxes of n_k/n_{k+1} texels per axis
// (n_{k+1} = ⌈n_k/2⌉: 2×2 averages for even sizes, fractional boxes for odd ones), down to 1×1,
// the tile's texel-averaged aBRDF. A pyramid stores the levels' texels one after the other:
// level k's texel (u, v) is pyramid texel first_k + u + n_u,k·v.
#pragma once
#include <cstdint>
#include <vector>

namespace btf {

struct MipLevel {
  int nu = 0, nv = 0;
  int64_t first = 0;  // its first texel in the pyramid
  int64_t texels() const { return int64_t(nu) * nv; }
  bool operator==(const MipLevel& o) const { return nu == o.nu && nv == o.nv && first == o.first; }
};

/// Every level of an nu × nv grid, level 0 first, the last 1×1.
std::vector<MipLevel> mipLevels(int nu, int nv);
/// Texels of all the levels together.
int64_t pyramidTexels(const std::vector<MipLevel>& levels);

/// The fine texels (and weights, summing to 1) that coarse texel j of m averages over n fine
/// ones: the box [j·n/m, (j+1)·n/m) in fine texel units.
struct BoxTap {
  int index = 0;
  double weight = 0;
};
std::vector<std::vector<BoxTap>> boxTaps(int n, int m);

}  // namespace btf
