#include "linalg.h"

#include <btf/core/error.h>
#include <btf/core/parallel.h>
#include <btf/core/rng.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>

namespace btf::la {
namespace {

// Gaussian test matrix from a counter-based stream (identical on every machine and thread count).
MatF gaussian(int rows, int cols, uint64_t seed) {
  MatF G(rows, cols);
  for (int j = 0; j < cols; ++j)
    for (int i = 0; i < rows; ++i) {
      const uint64_t h1 = hashKeys(seed, uint64_t(i), uint64_t(j), 1);
      const uint64_t h2 = hashKeys(seed, uint64_t(i), uint64_t(j), 2);
      const double u1 = (double(h1 >> 11) + 0.5) * (1.0 / 9007199254740992.0);
      const double u2 = double(h2 >> 11) * (1.0 / 9007199254740992.0);
      G(i, j) = float(std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2));
    }
  return G;
}

MatF orthonormalColumns(const MatF& Y) {
  Eigen::HouseholderQR<MatF> qr(Y);
  return qr.householderQ() * MatF::Identity(Y.rows(), Y.cols());
}

}  // namespace

Svd truncatedSvd(const MatF& A, int r, int powerIterations, uint64_t seed) {
  Svd out;
  const int m = int(A.rows()), n = int(A.cols());
  r = std::max(0, std::min(r, std::min(m, n)));
  if (r == 0) {
    out.s.resize(0);
    out.U.resize(m, 0);
    out.V.resize(n, 0);
    return out;
  }
  const int p = std::min(std::min(m, n), r + 8);  // oversampling
  MatF Q;
  if (p == std::min(m, n) && p <= 64) {
    // Small problem: the sketch would span everything anyway.
    Q = orthonormalColumns(m <= n ? MatF(MatF::Identity(m, m)) : MatF(A * gaussian(n, p, seed)));
    if (m > n) {
      for (int it = 0; it < powerIterations; ++it) Q = orthonormalColumns(A * (A.transpose() * Q));
    }
  } else {
    Q = orthonormalColumns(A * gaussian(n, p, seed));
    for (int it = 0; it < powerIterations; ++it) {
      const MatF Z = orthonormalColumns(A.transpose() * Q);
      Q = orthonormalColumns(A * Z);
    }
  }
  const MatF B = Q.transpose() * A;  // p × n
  Eigen::JacobiSVD<MatF> svd(B, Eigen::ComputeThinU | Eigen::ComputeThinV);
  out.s = svd.singularValues().head(r).cast<double>();
  out.U = Q * svd.matrixU().leftCols(r);
  out.V = svd.matrixV().leftCols(r);
  return out;
}

VecD singularValues(const MatF& A) {
  const bool tall = A.rows() >= A.cols();
  const Eigen::MatrixXd G =
      tall ? (A.transpose() * A).cast<double>().eval() : (A * A.transpose()).cast<double>().eval();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(G, Eigen::EigenvaluesOnly);
  VecD ev = es.eigenvalues().reverse();
  for (int i = 0; i < ev.size(); ++i) ev[i] = std::sqrt(std::max(0.0, ev[i]));
  return ev;
}

int rankForBeta(const VecD& s, double beta, BetaMode mode, double frobenius2, int kmax) {
  const int n = int(s.size());
  if (n == 0 || kmax <= 0) return 0;
  beta = std::clamp(beta, 0.0, 1.0);
  double total = 0;
  if (mode == BetaMode::Singular) {
    total = s.sum();
  } else {
    total = std::max(frobenius2, s.squaredNorm());
  }
  if (!(total > 0) || !(s[0] > 0)) return 0;
  double acc = 0;
  for (int k = 1; k <= n; ++k) {
    acc += mode == BetaMode::Singular ? s[k - 1] : s[k - 1] * s[k - 1];
    // Relative slack for rounding: a spectrum that reaches β exactly selects that k.
    if (acc >= beta * total * (1 - 1e-9)) return std::min(k, kmax);
    if (!(s[k - 1] > 0)) return std::min(k - 1, kmax);  // the rest is zero
  }
  return std::min(n, kmax);
}

BetaMode betaModeFromName(const std::string& name) {
  if (name == "singular") return BetaMode::Singular;
  if (name == "energy") return BetaMode::Energy;
  throw Error("unknown β mode '" + name + "' (expected singular or energy)");
}
std::string betaModeName(BetaMode m) {
  return m == BetaMode::Singular ? "singular" : "energy";
}

NmfSolver nmfSolverFromName(const std::string& name) {
  if (name == "hals") return NmfSolver::Hals;
  if (name == "mu" || name == "multiplicative") return NmfSolver::Multiplicative;
  throw Error("unknown NMF solver '" + name + "' (expected hals or mu)");
}
std::string nmfSolverName(NmfSolver s) {
  return s == NmfSolver::Hals ? "hals" : "mu";
}

void nndsvd(const Svd& svd, int k, MatF& W, MatF& H, float fill) {
  const int m = int(svd.U.rows()), n = int(svd.V.rows());
  k = std::min<int>(k, int(svd.s.size()));
  W = MatF::Zero(m, k);
  H = MatF::Zero(k, n);
  for (int j = 0; j < k; ++j) {
    const double sj = svd.s[j];
    if (!(sj > 0)) continue;
    const VecF x = svd.U.col(j), y = svd.V.col(j);
    if (j == 0) {
      W.col(0) = float(std::sqrt(sj)) * x.cwiseAbs();
      H.row(0) = float(std::sqrt(sj)) * y.cwiseAbs().transpose();
      continue;
    }
    const VecF xp = x.cwiseMax(0.f), xn = (-x).cwiseMax(0.f);
    const VecF yp = y.cwiseMax(0.f), yn = (-y).cwiseMax(0.f);
    const double xpn = xp.norm(), xnn = xn.norm(), ypn = yp.norm(), ynn = yn.norm();
    const double mp = xpn * ypn, mn = xnn * ynn;
    // Ties (x → −x symmetric) pick the positive part, so the result does not depend on the sign
    // the SVD happened to return only when mp ≠ mn; with mp = mn both choices have equal weight.
    const bool pos = mp >= mn;
    const double scale = std::sqrt(sj * (pos ? mp : mn));
    if (!(scale > 0)) continue;
    if (pos) {
      W.col(j) = float(scale / xpn) * xp;
      H.row(j) = float(scale / ypn) * yp.transpose();
    } else {
      W.col(j) = float(scale / xnn) * xn;
      H.row(j) = float(scale / ynn) * yn.transpose();
    }
  }
  if (fill > 0) {
    W = W.unaryExpr([fill](float v) { return v > 0 ? v : fill; });
    H = H.unaryExpr([fill](float v) { return v > 0 ? v : fill; });
  }
}

NmfResult nmf(const MatF& A, int k, const Svd& svd, NmfSolver solver, int maxIterations,
              double tol) {
  NmfResult r;
  const double norm2 = A.cast<double>().squaredNorm();
  k = std::min<int>(k, int(svd.s.size()));
  if (k <= 0 || !(norm2 > 0)) {
    r.W = MatF::Zero(A.rows(), 0);
    r.H = MatF::Zero(0, A.cols());
    return r;
  }
  const float fill =
      solver == NmfSolver::Multiplicative ? float(std::sqrt(norm2 / double(A.size())) * 1e-3) : 0.f;
  nndsvd(svd, k, r.W, r.H, fill);
  const float tiny = 1e-30f;
  double prev = -1;
  for (int it = 0; it < maxIterations; ++it) {
    // H update with W fixed.
    const MatF WtA = r.W.transpose() * A;  // k × n
    const MatF WtW = r.W.transpose() * r.W;
    if (solver == NmfSolver::Hals) {
      for (int j = 0; j < k; ++j) {
        const float d = WtW(j, j);
        if (!(d > tiny)) continue;
        r.H.row(j) = (r.H.row(j) + (WtA.row(j) - WtW.row(j) * r.H) / d).cwiseMax(0.f);
      }
    } else {
      const MatF den = WtW * r.H;
      r.H = r.H.cwiseProduct(WtA.cwiseQuotient(den.cwiseMax(tiny)));
    }
    // Objective of (W, H_new): ‖A‖² − 2⟨WᵀA, H⟩ + ⟨WᵀW, H Hᵀ⟩.
    const MatF HHt = r.H * r.H.transpose();
    double f = norm2 - 2.0 * WtA.cast<double>().cwiseProduct(r.H.cast<double>()).sum() +
               WtW.cast<double>().cwiseProduct(HHt.cast<double>()).sum();
    f = std::max(0.0, f);
    r.objective.push_back(f);
    r.iterations = it + 1;
    if (tol > 0 && prev >= 0 && prev - f <= tol * prev) break;
    if (f <= 1e-14 * norm2) break;
    prev = f;
    // W update with H fixed.
    const MatF AHt = A * r.H.transpose();  // m × k
    if (solver == NmfSolver::Hals) {
      for (int j = 0; j < k; ++j) {
        const float d = HHt(j, j);
        if (!(d > tiny)) continue;
        r.W.col(j) = (r.W.col(j) + (AHt.col(j) - r.W * HHt.col(j)) / d).cwiseMax(0.f);
      }
    } else {
      const MatF den = r.W * HHt;
      r.W = r.W.cwiseProduct(AHt.cwiseQuotient(den.cwiseMax(tiny)));
    }
  }
  return r;
}

Eigen::MatrixXd gramOfColumns(const MatF& X) {
  // Σ over row blocks of X_bᵀ X_b in double (the eigenvectors of a float Gram lose half the
  // digits); blocks are summed in a fixed order (deterministic).
  const int64_t rows = X.rows();
  const int d = int(X.cols());
  const int64_t block = std::max<int64_t>(1024, (rows + 15) / 16);
  const int nb = int((rows + block - 1) / block);
  std::vector<Eigen::MatrixXd> parts(size_t(std::max(nb, 1)), Eigen::MatrixXd::Zero(d, d));
  parallelForChunks(nb, 1, [&](int64_t b0, int64_t b1) {
    for (int64_t b = b0; b < b1; ++b) {
      const int64_t r0 = b * block, r1 = std::min(rows, r0 + block);
      const Eigen::MatrixXd blk = X.middleRows(r0, r1 - r0).cast<double>();
      parts[size_t(b)].selfadjointView<Eigen::Lower>().rankUpdate(blk.transpose());
      parts[size_t(b)] = parts[size_t(b)].selfadjointView<Eigen::Lower>();
    }
  });
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(d, d);
  for (const auto& p : parts) G += p;
  return G;
}

Basis pcaBasis(const MatF& X, int c) {
  Basis b;
  const int dim = int(X.rows()), n = int(X.cols());
  b.total = X.cast<double>().squaredNorm();
  if (dim == 0 || n == 0 || !(b.total > 0)) {
    b.B = MatF::Zero(dim, 0);
    b.eigen = VecD::Zero(0);
    return b;
  }
  const bool samplesSide = n <= dim;  // Gram of samples (n × n) when there are fewer samples
  const Eigen::MatrixXd G = samplesSide ? gramOfColumns(X) : gramOfColumns(X.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(G);
  const VecD ev = es.eigenvalues().reverse().cwiseMax(0.0);
  const Eigen::MatrixXd vecs = es.eigenvectors().rowwise().reverse();
  b.eigen = ev;
  int keep = 0;
  // Float data carries rounding noise of ~1e-12 of the largest eigenvalue: below is no signal.
  const double floor = 1e-12 * ev[0];
  while (keep < std::min<int>(c, int(ev.size())) && ev[keep] > floor && ev[keep] > 0) ++keep;
  if (samplesSide) {
    // u_i = X v_i / √λ_i, re-normalised (rounding).
    b.B = X * vecs.leftCols(keep).cast<float>();
    for (int i = 0; i < keep; ++i) {
      const float nrm = b.B.col(i).norm();
      if (nrm > 0) b.B.col(i) /= nrm;
    }
  } else {
    b.B = vecs.leftCols(keep).cast<float>();
  }
  return b;
}

Basis pcaBasisFromGram(const Eigen::MatrixXd& G, int c) {
  Basis b;
  const int dim = int(G.rows());
  b.total = G.trace();
  if (dim == 0 || !(b.total > 0)) {
    b.B = MatF::Zero(dim, 0);
    b.eigen = VecD::Zero(0);
    return b;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(G);
  const VecD ev = es.eigenvalues().reverse().cwiseMax(0.0);
  const Eigen::MatrixXd vecs = es.eigenvectors().rowwise().reverse();
  b.eigen = ev;
  int keep = 0;
  const double floor = 1e-12 * ev[0];  // as pcaBasis: rounding noise of float data below it
  while (keep < std::min<int>(c, int(ev.size())) && ev[keep] > floor && ev[keep] > 0) ++keep;
  b.B = vecs.leftCols(keep).cast<float>();
  return b;
}

int componentsForResidual(const Basis& b, double residual) {
  if (!(b.total > 0)) return 0;
  double acc = 0;
  for (int i = 0; i < b.eigen.size(); ++i) {
    acc += b.eigen[i];
    if (b.total - acc <= std::max(residual, 1e-6) * b.total) return i + 1;
  }
  return int(b.eigen.size());
}

uint16_t floatToHalf(float f) {
  if (!std::isfinite(f)) {
    if (std::isnan(f)) return 0;
    f = f > 0 ? 65504.f : -65504.f;
  }
  uint32_t x;
  std::memcpy(&x, &f, 4);
  const uint32_t sign = (x >> 16) & 0x8000u;
  x &= 0x7fffffffu;
  if (x >= 0x477fe000u) return uint16_t(sign | 0x7bffu);  // ≥ 65520 after rounding: saturate
  if (x < 0x38800000u) {                                  // subnormal half or zero
    if (x < 0x33000000u) return uint16_t(sign);           // < 2^-25: rounds to 0
    const uint32_t e = x >> 23;
    const uint32_t mant = (x & 0x7fffffu) | 0x800000u;
    const uint32_t shift = 126 - e;  // 14 + (113 - e) … value = mant · 2^(e-150)
    const uint32_t half = mant >> shift;
    const uint32_t rem = mant & ((1u << shift) - 1u);
    const uint32_t mid = 1u << (shift - 1);
    uint32_t r = half + ((rem > mid || (rem == mid && (half & 1u))) ? 1u : 0u);
    return uint16_t(sign | r);
  }
  uint32_t r = x - 0x38000000u;  // rebias exponent 127 → 15
  const uint32_t rem = r & 0x1fffu;
  r >>= 13;
  if (rem > 0x1000u || (rem == 0x1000u && (r & 1u))) ++r;
  return uint16_t(sign | r);
}

float halfToFloat(uint16_t h) {
  const uint32_t sign = uint32_t(h & 0x8000u) << 16;
  const uint32_t e = (h >> 10) & 0x1fu, m = h & 0x3ffu;
  uint32_t x;
  if (e == 0) {
    if (m == 0) {
      x = sign;
    } else {  // subnormal: m · 2^-24
      const float v = float(m) * (1.f / 16777216.f);
      return sign ? -v : v;
    }
  } else if (e == 31) {
    x = sign | 0x7f800000u | (m << 13);
  } else {
    x = sign | ((e + 112u) << 23) | (m << 13);
  }
  float f;
  std::memcpy(&f, &x, 4);
  return f;
}

}  // namespace btf::la
