#include "tensor.h"

#include <btf/core/error.h>
#include <btf/core/rng.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace btf::la {

// ------------------------------------------------------------------ sketches

SignSketch::SignSketch(int64_t inputDim, int outputDim, uint64_t seed) : m_d(outputDim) {
  if (outputDim < 1 || outputDim > kMaxDim || (outputDim & (outputDim - 1)))
    throw Error("sign sketch: the dimension must be a power of two in 1.." +
                std::to_string(kMaxDim));
  m_code.resize(size_t(inputDim));
  for (int64_t i = 0; i < inputDim; ++i) {
    const uint64_t h = hashKeys(seed, uint64_t(i), 0x5ce7c4);
    m_code[size_t(i)] = uint16_t((h & uint64_t(outputDim - 1)) | ((h >> 63) << 15));
  }
}

void SignSketch::apply(const float* x, float* out) const {
  // Accumulated in double: the sketch of the same texel is the same bits wherever it is made.
  double acc[kMaxDim];
  std::fill(acc, acc + m_d, 0.0);
  for (size_t i = 0; i < m_code.size(); ++i) {
    const uint16_t c = m_code[i];
    acc[c & 0x7fff] += (c & 0x8000) ? -double(x[i]) : double(x[i]);
  }
  for (int j = 0; j < m_d; ++j) out[j] = float(acc[j]);
}

MatF foldSketch(const MatF& X, int d) {
  MatF Y = MatF::Zero(d, X.cols());
  for (int64_t c = 0; c < X.cols(); ++c)
    for (int64_t r = 0; r < X.rows(); ++r) Y(r % d, c) += X(r, c);
  return Y;
}

// ------------------------------------------------------------------ IRP k-means

int nearestCentre(const MatF& centres, const float* x) {
  int best = 0;
  double bd = std::numeric_limits<double>::infinity();
  for (int64_t k = 0; k < centres.cols(); ++k) {
    double d = 0;
    for (int64_t r = 0; r < centres.rows(); ++r) {
      const double e = double(centres(r, k)) - double(x[r]);
      d += e * e;
    }
    if (d < bd) bd = d, best = int(k);
  }
  return best;
}

namespace {

double dist2(const MatF& A, int64_t i, const MatF& B, int64_t j) {
  double d = 0;
  for (int64_t r = 0; r < A.rows(); ++r) {
    const double e = double(A(r, i)) - double(B(r, j));
    d += e * e;
  }
  return d;
}

// Lloyd iterations from the given assignment (centres recomputed from it first). An empty
// cluster takes the point farthest from its centre.
void lloyd(const MatF& Y, int K, std::vector<int>& assign, MatF& cent, int maxIterations,
           KMeansResult& res) {
  const int64_t n = Y.cols();
  for (int it = 0; it < maxIterations; ++it) {
    // Means of the current assignment (double sums, fixed order).
    Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(Y.rows(), K);
    std::vector<int64_t> count(size_t(K), 0);
    for (int64_t i = 0; i < n; ++i) {
      sum.col(assign[size_t(i)]) += Y.col(i).cast<double>();
      count[size_t(assign[size_t(i)])]++;
    }
    cent.resize(Y.rows(), K);
    for (int k = 0; k < K; ++k)
      if (count[size_t(k)] > 0) cent.col(k) = (sum.col(k) / double(count[size_t(k)])).cast<float>();
    for (int k = 0; k < K; ++k) {
      if (count[size_t(k)] > 0) continue;
      int64_t far = 0;
      double best = -1;
      for (int64_t i = 0; i < n; ++i) {
        if (count[size_t(assign[size_t(i)])] <= 1) continue;  // would empty another cluster
        const double d = dist2(Y, i, cent, assign[size_t(i)]);
        if (d > best) best = d, far = i;
      }
      count[size_t(assign[size_t(far)])]--;
      assign[size_t(far)] = k;
      count[size_t(k)] = 1;
      cent.col(k) = Y.col(far);
      ++res.reseeds;
    }
    bool changed = false;
    for (int64_t i = 0; i < n; ++i) {
      std::vector<float> y(Y.col(i).data(), Y.col(i).data() + Y.rows());
      const int a = nearestCentre(cent, y.data());
      if (a != assign[size_t(i)]) changed = true, assign[size_t(i)] = a;
    }
    ++res.iterations;
    if (!changed) break;
  }
}

}  // namespace

KMeansResult irpKMeans(const MatF& X, int K, uint64_t seed, int maxIterations) {
  KMeansResult res;
  const int64_t n = X.cols();
  const int D = int(X.rows());
  if (n == 0 || D == 0) return res;
  K = int(std::max<int64_t>(1, std::min<int64_t>(K, n)));
  for (int d = 2; d < D; d *= 2) res.dims.push_back(d);
  res.dims.push_back(D);
  std::vector<int> assign(size_t(n), 0);
  MatF cent;
  for (size_t level = 0; level < res.dims.size(); ++level) {
    const MatF Y = res.dims[level] == D ? X : foldSketch(X, res.dims[level]);
    if (level == 0) {
      // k-means++ seeding (a deterministic stream of the seed).
      Rng rng(seed * 0x9e3779b97f4a7c15ULL + 29);
      cent.resize(Y.rows(), K);
      std::vector<double> d2(size_t(n), std::numeric_limits<double>::infinity());
      cent.col(0) = Y.col(int64_t(rng.next() % uint64_t(n)));
      for (int k = 1; k < K; ++k) {
        double total = 0;
        for (int64_t i = 0; i < n; ++i) {
          d2[size_t(i)] = std::min(d2[size_t(i)], dist2(Y, i, cent, k - 1));
          total += d2[size_t(i)];
        }
        double r = rng.uniformDouble() * total;
        int64_t pick = n - 1;
        for (int64_t i = 0; i < n; ++i) {
          r -= d2[size_t(i)];
          if (r < 0) {
            pick = i;
            break;
          }
        }
        cent.col(k) = Y.col(pick);
      }
      for (int64_t i = 0; i < n; ++i) {
        std::vector<float> y(Y.col(i).data(), Y.col(i).data() + Y.rows());
        assign[size_t(i)] = nearestCentre(cent, y.data());
      }
    }
    lloyd(Y, K, assign, cent, maxIterations, res);
  }
  res.centres = cent;
  res.assign = std::move(assign);
  return res;
}

// ------------------------------------------------------------------ Tucker

void symmetricEigen(const Eigen::MatrixXd& G, VecD& values, Eigen::MatrixXd& vectors) {
  const int64_t n = G.rows();
  values.resize(n);
  vectors.resize(n, n);
  if (n == 0) return;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (G + G.transpose()));
  // Ascending from Eigen: reverse.
  for (int64_t i = 0; i < n; ++i) {
    values[i] = std::max(0.0, es.eigenvalues()[n - 1 - i]);
    vectors.col(i) = es.eigenvectors().col(n - 1 - i);
  }
}

namespace {

Eigen::MatrixXd viewGram(const std::vector<const MatF*>& A) {
  const int64_t n = A.empty() ? 0 : A[0]->rows();
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, n);
  for (const MatF* a : A) G += (*a * a->transpose()).cast<double>();
  return G;
}
Eigen::MatrixXd lightGram(const std::vector<const MatF*>& A) {
  const int64_t n = A.empty() ? 0 : A[0]->cols();
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, n);
  for (const MatF* a : A) G += (a->transpose() * *a).cast<double>();
  return G;
}
MatF topVectors(const Eigen::MatrixXd& G, int r) {
  VecD ev;
  Eigen::MatrixXd V;
  symmetricEigen(G, ev, V);
  return V.leftCols(r).cast<float>();
}

// Texel step: Z (m × Rv·Rl) rows vec(Uvᵀ A_i Ul); Ut its top Rt left singular vectors; the core
// slices and the error follow.
void texelStep(const std::vector<const MatF*>& A, Tucker3& t, int Rt) {
  const int64_t m = int64_t(A.size());
  const int64_t Rv = t.Uv.cols(), Rl = t.Ul.cols();
  Eigen::MatrixXd Z(m, Rv * Rl);
  for (int64_t i = 0; i < m; ++i) {
    const MatF S = t.Uv.transpose() * (*A[size_t(i)]) * t.Ul;
    for (int64_t b = 0; b < Rl; ++b)
      for (int64_t a = 0; a < Rv; ++a) Z(i, a + Rv * b) = S(a, b);
  }
  Eigen::BDCSVD<Eigen::MatrixXd> svd(Z, Eigen::ComputeThinU);
  const int64_t r = std::min<int64_t>(Rt, svd.matrixU().cols());
  t.Ut = svd.matrixU().leftCols(r).cast<float>();
  const Eigen::MatrixXd core = svd.matrixU().leftCols(r).transpose() * Z;  // r × Rv·Rl
  t.coreSlices.assign(size_t(r), MatF(Rv, Rl));
  for (int64_t c = 0; c < r; ++c)
    for (int64_t b = 0; b < Rl; ++b)
      for (int64_t a = 0; a < Rv; ++a) t.coreSlices[size_t(c)](a, b) = float(core(c, a + Rv * b));
  t.error = std::max(0.0, t.energy - core.squaredNorm());
}

}  // namespace

ModeSpectra modeSpectra(const std::vector<const MatF*>& A, int keepVectors) {
  ModeSpectra s;
  const int64_t m = int64_t(A.size());
  Eigen::MatrixXd V;
  symmetricEigen(viewGram(A), s.view, V);
  s.viewVectors = V.leftCols(std::min<int64_t>(keepVectors, V.cols())).cast<float>();
  symmetricEigen(lightGram(A), s.light, V);
  s.lightVectors = V.leftCols(std::min<int64_t>(keepVectors, V.cols())).cast<float>();
  Eigen::MatrixXd G(m, m);
  for (int64_t i = 0; i < m; ++i)
    for (int64_t j = 0; j <= i; ++j) {
      const double d = double(A[size_t(i)]->cwiseProduct(*A[size_t(j)]).cast<double>().sum());
      G(i, j) = G(j, i) = d;
    }
  symmetricEigen(G, s.texel, V);
  for (int64_t i = 0; i < m; ++i) s.energy += G(i, i);
  return s;
}

Tucker3 hooi(const std::vector<const MatF*>& A, int Rv, int Rl, int Rt, int sweeps,
             std::vector<double>* errors, const ModeSpectra* start) {
  Tucker3 t;
  if (A.empty()) return t;
  const int64_t nV = A[0]->rows(), nL = A[0]->cols(), m = int64_t(A.size());
  for (const MatF* a : A) {
    if (a->rows() != nV || a->cols() != nL) throw Error("hooi: slices of different shapes");
    t.energy += a->cast<double>().squaredNorm();
  }
  Rv = int(std::clamp<int64_t>(Rv, 0, nV));
  Rl = int(std::clamp<int64_t>(Rl, 0, nL));
  Rt = int(std::clamp<int64_t>(Rt, 0, std::min<int64_t>(m, int64_t(Rv) * Rl)));
  if (start && start->viewVectors.cols() >= Rv && start->lightVectors.cols() >= Rl &&
      start->viewVectors.rows() == nV && start->lightVectors.rows() == nL) {
    t.Uv = start->viewVectors.leftCols(Rv);
    t.Ul = start->lightVectors.leftCols(Rl);
  } else {
    t.Uv = topVectors(viewGram(A), Rv);
    t.Ul = topVectors(lightGram(A), Rl);
  }
  texelStep(A, t, Rt);
  if (errors) errors->push_back(t.error);
  for (int s = 0; s < sweeps && Rt > 0; ++s) {
    // View mode: W (nV × Rl·Rt), W[:, b + Rl·c] = Σ_i Ut(i, c) (A_i Ul)[:, b].
    {
      Eigen::MatrixXd W = Eigen::MatrixXd::Zero(nV, int64_t(Rl) * Rt);
      for (int64_t i = 0; i < m; ++i) {
        const Eigen::MatrixXd P = ((*A[size_t(i)]) * t.Ul).cast<double>();
        for (int c = 0; c < Rt; ++c) W.middleCols(int64_t(c) * Rl, Rl) += double(t.Ut(i, c)) * P;
      }
      t.Uv = topVectors(W * W.transpose(), Rv);
    }
    {
      Eigen::MatrixXd W = Eigen::MatrixXd::Zero(nL, int64_t(Rv) * Rt);
      for (int64_t i = 0; i < m; ++i) {
        const Eigen::MatrixXd P = (A[size_t(i)]->transpose() * t.Uv).cast<double>();
        for (int c = 0; c < Rt; ++c) W.middleCols(int64_t(c) * Rv, Rv) += double(t.Ut(i, c)) * P;
      }
      t.Ul = topVectors(W * W.transpose(), Rl);
    }
    texelStep(A, t, Rt);
    if (errors) errors->push_back(t.error);
  }
  return t;
}

}  // namespace btf::la
