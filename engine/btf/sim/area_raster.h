// Exact area coverage of polygons over a grid of unit cells — the signed-area accumulation of
// font rasterisers. Every edge adds, in each cell it crosses, the trapezoid between itself and
// the cell's right side, and its full height to the cell after it in a difference array; a
// prefix sum along each row then gives every cell the (weighted) area of the polygons inside it.
// Exact for straight edges, any polygon (holes, several rings, non-convex) whose rings are
// oriented (counter-clockwise adds, clockwise subtracts). Rows wrap (the tile is periodic);
// columns run past the period to the right and fold onto it after the prefix sum.
#pragma once
#include <algorithm>
#include <cmath>
#include <vector>

namespace btf {

class AreaRaster {
 public:
  static constexpr int kChannels = 3;

  /// A grid of nu × nv cells of which rows [rowBegin, rowEnd) are kept; polygons' x must lie
  /// in [0, width − 2] (the caller shifts each by whole periods).
  void reset(int nu, int nv, int rowBegin, int rowEnd, int width) {
    m_nu = nu, m_nv = nv, m_r0 = rowBegin, m_r1 = rowEnd, m_w = std::max(width, nu + 2);
    m_acc.assign(size_t(m_r1 - m_r0) * size_t(m_w) * kChannels, 0.0);
  }
  int width() const { return m_w; }

  /// Edge (x0, y0) → (x1, y1) in cell units, weighted by w[kChannels]; a counter-clockwise ring
  /// adds w × its area to the cells it covers.
  void addEdge(double x0, double y0, double x1, double y1, const double* w) {
    if (!(y0 != y1)) return;  // horizontal (or NaN): no area
    const double dir = y1 > y0 ? 1.0 : -1.0;
    const double ya = std::min(y0, y1), yb = std::max(y0, y1);
    const double xa = y1 > y0 ? x0 : x1, xb = y1 > y0 ? x1 : x0;  // x at ya and at yb
    const double slope = (xb - xa) / (yb - ya);                    // dx per dy
    const int r0 = int(std::floor(ya)), r1 = int(std::ceil(yb));
    for (int r = r0; r < r1; ++r) {
      int row = r % m_nv;
      if (row < 0) row += m_nv;
      if (row < m_r0 || row >= m_r1) continue;
      const double s0 = std::max(ya, double(r)), s1 = std::min(yb, double(r + 1));
      if (!(s1 > s0)) continue;
      const double ex0 = xa + (s0 - ya) * slope, ex1 = xa + (s1 - ya) * slope;
      // Counter-clockwise rings go down on their left side: a point inside has edges of
      // negative dy on its left, hence the sign.
      addSpan(row, ex0, ex1, -dir * (s1 - s0), w);
    }
  }

  /// Cell (i, j)'s accumulated value of channel c (after resolve), j in [rowBegin, rowEnd).
  double value(int i, int j, int c) const {
    return m_acc[(size_t(j - m_r0) * size_t(m_w) + size_t(i)) * kChannels + size_t(c)];
  }

  /// Prefix sums along every row, then columns folded modulo nu (cells [0, nu) hold the sums).
  void resolve() {
    for (int r = 0; r < m_r1 - m_r0; ++r) {
      double* row = &m_acc[size_t(r) * size_t(m_w) * kChannels];
      double run[kChannels] = {0, 0, 0};
      for (int x = 0; x < m_w; ++x)
        for (int c = 0; c < kChannels; ++c) {
          run[c] += row[size_t(x) * kChannels + size_t(c)];
          row[size_t(x) * kChannels + size_t(c)] = run[c];
        }
      for (int x = m_nu; x < m_w; ++x)
        for (int c = 0; c < kChannels; ++c)
          row[size_t(x % m_nu) * kChannels + size_t(c)] += row[size_t(x) * kChannels + size_t(c)];
    }
  }

 private:
  // A piece of edge inside row `row` from x = ex0 to ex1 with signed height h: split at the
  // column boundaries; each piece in cell c adds h·(1 − f) to c and h·f to c + 1, f its mean x
  // within the cell.
  void addSpan(int row, double ex0, double ex1, double h, const double* w) {
    double* acc = &m_acc[size_t(row - m_r0) * size_t(m_w) * kChannels];
    const double lo = std::min(ex0, ex1), hi = std::max(ex0, ex1);
    const int cmax = m_w - 2;
    auto put = [&](int c, double f, double hh) {
      c = std::min(std::max(c, 0), cmax);
      for (int k = 0; k < kChannels; ++k) {
        acc[size_t(c) * kChannels + size_t(k)] += w[k] * hh * (1 - f);
        acc[size_t(c + 1) * kChannels + size_t(k)] += w[k] * hh * f;
      }
    };
    const int c0 = int(std::floor(lo));
    if (hi - lo < 1e-12 || int(std::floor(hi)) == c0) {
      put(c0, 0.5 * (lo + hi) - c0, h);
      return;
    }
    const double len = hi - lo;
    for (int c = c0; double(c) < hi; ++c) {
      const double a = std::max(lo, double(c)), b = std::min(hi, double(c + 1));
      if (!(b > a)) continue;
      put(c, 0.5 * (a + b) - c, h * (b - a) / len);
    }
  }

  int m_nu = 1, m_nv = 1, m_r0 = 0, m_r1 = 1, m_w = 3;
  std::vector<double> m_acc;  // rows × width × channels
};

}  // namespace btf
