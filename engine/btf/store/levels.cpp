#include <btf/core/error.h>
#include <btf/store/levels.h>

#include <algorithm>
#include <string>

namespace btf {

std::vector<MipLevel> mipLevels(int nu, int nv) {
  if (nu < 1 || nv < 1)
    throw Error("texel levels of a " + std::to_string(nu) + "×" + std::to_string(nv) + " grid");
  std::vector<MipLevel> out;
  MipLevel l{nu, nv, 0};
  for (;;) {
    out.push_back(l);
    if (l.nu == 1 && l.nv == 1) break;
    const int64_t next = l.first + l.texels();
    l = MipLevel{(l.nu + 1) / 2, (l.nv + 1) / 2, next};
  }
  return out;
}

int64_t pyramidTexels(const std::vector<MipLevel>& levels) {
  return levels.empty() ? 0 : levels.back().first + levels.back().texels();
}

std::vector<std::vector<BoxTap>> boxTaps(int n, int m) {
  // Exact in integers: fine texel i covers [i·m, (i+1)·m) and coarse texel j [j·n, (j+1)·n) on a
  // common axis of n·m units.
  std::vector<std::vector<BoxTap>> taps(size_t(std::max(m, 0)));
  for (int j = 0; j < m; ++j) {
    const int64_t lo = int64_t(j) * n, hi = int64_t(j + 1) * n;
    for (int64_t i = lo / m; i < n && i * m < hi; ++i) {
      const int64_t a = std::max(lo, i * m), b = std::min(hi, (i + 1) * m);
      if (b > a) taps[size_t(j)].push_back({int(i), double(b - a) / double(n)});
    }
  }
  return taps;
}

}  // namespace btf
