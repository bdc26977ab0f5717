// Order-independent sums (docs/cluster.md): each term rounded once to a fixed grid of 2^-50 and
// added as a 128-bit integer, so a sum is the same bits whatever the order of its terms, the
// threads or the ranks that added them. For statistics a file depends on (the nmf codec's
// residuals and Gram matrices).
#pragma once
#include <cmath>
#include <vector>

namespace btf {

__extension__ typedef __int128 Exact;

constexpr double kExactScale = 1125899906842624.0;  // 2^50

/// |x| < 2^76; a non-finite x (which no caller should pass) counts as 0 rather than as undefined
/// behaviour in the conversion.
inline Exact toExact(double x) {
  const double y = std::nearbyint(x * kExactScale);
  return std::isfinite(y) && std::abs(y) < 0x1p126 ? Exact(y) : Exact(0);
}
inline double fromExact(Exact v) {
  return double(v) / kExactScale;
}

}  // namespace btf
