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
  /// `linear`: addLinearEdge may be called (a second accumulator for the x-slopes).
  void reset(int nu, int nv, int rowBegin, int rowEnd, int width, bool linear = false) {
    m_nu = nu, m_nv = nv, m_r0 = rowBegin, m_r1 = rowEnd, m_w = std::max(width, nu + 2);
    m_acc.assign(size_t(m_r1 - m_r0) * size_t(m_w) * kChannels, 0.0);
    m_linear = linear;
    if (linear) m_slope.assign(m_acc.size(), 0.0);
  }
  int width() const { return m_w; }

  /// Edge (x0, y0) → (x1, y1) in cell units, weighted by w[kChannels]; a counter-clockwise ring
  /// adds w × its area to the cells it covers.
  void addEdge(double x0, double y0, double x1, double y1, const double* w) {
    // Counter-clockwise rings go down on their left side: a point inside has edges of
    // negative dy on its left, hence the sign.
    rowPieces(x0, y0, x1, y1, [&](int row, double ex0, double s0, double ex1, double s1, double sign) {
      addSpan(row, ex0, ex1, sign * (s1 - s0), w);
    });
  }

  /// The same edge for an integrand linear over the cells: channel k's value at cell point
  /// (x, y) (unwrapped, the coordinates of the edges) is a[k] + b[k]·x + g[k]·y, and each cell
  /// gets the exact integral of it over the ring's part inside the cell (reset with linear).
  void addLinearEdge(double x0, double y0, double x1, double y1, const double* a, const double* b,
                     const double* g) {
    rowPieces(x0, y0, x1, y1, [&](int row, double ex0, double s0, double ex1, double s1, double sign) {
      // Split at the column boundaries along y: each piece lies in one column.
      const double lo = std::min(ex0, ex1), hi = std::max(ex0, ex1);
      const int c0 = int(std::floor(lo));
      if (hi - lo < 1e-12 || int(std::floor(hi)) == c0) {
        linearPiece(row, c0, ex0, s0, ex1, s1, sign, a, b, g);
        return;
      }
      const double inv = 1.0 / (ex1 - ex0);
      for (int c = c0; double(c) < hi; ++c) {
        const double ua = std::max(lo, double(c)), ub = std::min(hi, double(c + 1));
        if (!(ub > ua)) continue;
        const double ta = (ua - ex0) * inv, tb = (ub - ex0) * inv;  // along the piece, 0 … 1
        const double ya2 = s0 + std::min(ta, tb) * (s1 - s0), yb2 = s0 + std::max(ta, tb) * (s1 - s0);
        // x at ya2 and at yb2 (the piece's ends, in the order of y)
        const double xs = ex0 + std::min(ta, tb) * (ex1 - ex0), xe = ex0 + std::max(ta, tb) * (ex1 - ex0);
        linearPiece(row, c, xs, ya2, xe, yb2, sign, a, b, g);
      }
    });
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
      if (m_linear) {
        // Whole cells right of a piece: its slope's share, b·Δy·(x + ½) at column x.
        const double* sl = &m_slope[size_t(r) * size_t(m_w) * kChannels];
        double srun[kChannels] = {0, 0, 0};
        for (int x = 0; x < m_w; ++x)
          for (int c = 0; c < kChannels; ++c) {
            srun[c] += sl[size_t(x) * kChannels + size_t(c)];
            row[size_t(x) * kChannels + size_t(c)] += srun[c] * (double(x) + 0.5);
          }
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

  // The edge's pieces within each kept row (rows wrap): fn(row, x at s0, s0, x at s1, s1,
  // sign) with s0 < s1, sign −1 for an edge going up in y, +1 going down.
  template <class Fn>
  void rowPieces(double x0, double y0, double x1, double y1, Fn&& fn) const {
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
      fn(row, xa + (s0 - ya) * slope, s0, xa + (s1 - ya) * slope, s1, -dir);
    }
  }

  // A piece of edge inside cell column c of row `row`, from (x0, y0) to (x1, y1) with
  // y0 ≤ y1, sign ±1: the integral of a + b·x + g·y over the part of the cell right of the piece
  // goes to cell c, and the whole cells after it get the rest through the prefix sums (the
  // constant and y parts in m_acc, the x-slope in m_slope).
  void linearPiece(int row, int c, double x0, double y0, double x1, double y1, double sign,
                   const double* a, const double* b, const double* g) {
    c = std::min(std::max(c, 0), m_w - 2);
    const double dy = y1 - y0, ym = 0.5 * (y0 + y1), right = double(c + 1);
    const double xm = 0.5 * (x0 + x1);
    double* acc = &m_acc[size_t(row - m_r0) * size_t(m_w) * kChannels];
    double* sl = &m_slope[size_t(row - m_r0) * size_t(m_w) * kChannels];
    for (int k = 0; k < kChannels; ++k) {
      // ∫ over y of (a + g·y)(right − x(y)) + ½ b (right² − x(y)²): quadratic in y, so Simpson
      // is exact.
      auto F = [&](double x, double y) {
        return (a[k] + g[k] * y) * (right - x) + 0.5 * b[k] * (right * right - x * x);
      };
      const double inCell = dy / 6 * (F(x0, y0) + 4 * F(xm, ym) + F(x1, y1));
      const double slab = dy * (a[k] + g[k] * ym);  // a whole cell's constant and y parts
      acc[size_t(c) * kChannels + size_t(k)] += sign * inCell;
      acc[size_t(c + 1) * kChannels + size_t(k)] += sign * (slab - inCell);
      sl[size_t(c + 1) * kChannels + size_t(k)] += sign * b[k] * dy;
    }
  }

  int m_nu = 1, m_nv = 1, m_r0 = 0, m_r1 = 1, m_w = 3;
  bool m_linear = false;
  std::vector<double> m_acc;    // rows × width × channels
  std::vector<double> m_slope;  // the same, for the x-slopes of linear integrands
};

}  // namespace btf
