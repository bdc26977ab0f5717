// The compressors' linear algebra: exact low-rank reconstructions, the β rule on constructed
// spectra, NMF invariants (non-negativity, monotone objective, deterministic NNDSVD), hard
// inputs, PCA bases and half floats.
#include <btf/compress/linalg.h>
#include <btf/core/rng.h>
#include <gtest/gtest.h>

#include <cmath>

using namespace btf;
using namespace btf::la;

namespace {

MatF randomMatrix(int m, int n, uint64_t seed, float lo = 0.f, float hi = 1.f) {
  Rng rng(seed);
  MatF A(m, n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < m; ++i) A(i, j) = lo + (hi - lo) * uniformFloat(rng.next());
  return A;
}

MatF orthonormal(int m, int k, uint64_t seed) {
  Eigen::HouseholderQR<MatF> qr(randomMatrix(m, k, seed, -1.f, 1.f));
  return qr.householderQ() * MatF::Identity(m, k);
}

double relErr(const MatF& A, const MatF& B) {
  return (A - B).cast<double>().norm() / std::max(1e-300, A.cast<double>().norm());
}

bool allFinite(const MatF& A) {
  return A.allFinite();
}

}  // namespace

TEST(Linalg, TruncatedSvdReconstructsRankKExactly) {
  for (int k : {1, 3, 6}) {
    const MatF A = randomMatrix(80, k, 10 + uint64_t(k)) * randomMatrix(k, 64, 20 + uint64_t(k));
    const Svd s = truncatedSvd(A, k);
    ASSERT_EQ(s.s.size(), k);
    const MatF R = s.U * s.s.cast<float>().asDiagonal() * s.V.transpose();
    EXPECT_LT(relErr(A, R), 2e-6) << "rank " << k;
    // Orthonormal factors.
    EXPECT_LT((s.U.transpose() * s.U - MatF::Identity(k, k)).norm(), 1e-5);
    EXPECT_LT((s.V.transpose() * s.V - MatF::Identity(k, k)).norm(), 1e-5);
  }
}

TEST(Linalg, NmfReconstructsNonNegativeLowRankMatrices) {
  // Rank 1: NNDSVD alone is exact (W = √σ|u|, H = √σ|v|).
  const MatF a = randomMatrix(50, 1, 3, 0.1f, 1.f), b = randomMatrix(1, 40, 4, 0.1f, 1.f);
  const MatF A1 = a * b;
  const NmfResult r1 = nmf(A1, 1, truncatedSvd(A1, 4), NmfSolver::Hals, 5, 0);
  EXPECT_LT(relErr(A1, r1.W * r1.H), 1e-6);
  // Rank k with non-negative factors: HALS converges to the exact factorisation.
  for (int k : {2, 4}) {
    const MatF A = randomMatrix(60, k, 30 + uint64_t(k)) * randomMatrix(k, 48, 40 + uint64_t(k));
    const NmfResult r = nmf(A, k, truncatedSvd(A, k), NmfSolver::Hals, 3000, 0);
    EXPECT_LT(relErr(A, r.W * r.H), 2e-3) << "rank " << k << " after " << r.iterations;
    EXPECT_GE(r.W.minCoeff(), 0.f);
    EXPECT_GE(r.H.minCoeff(), 0.f);
  }
}

TEST(Linalg, BetaSelectsTheExpectedRankOnConstructedSpectra) {
  // σ = 4, 3, 2, 1: Σσ = 10, Σσ² = 30.
  const VecD s = (VecD(4) << 4, 3, 2, 1).finished();
  EXPECT_EQ(rankForBeta(s, 0.4, BetaMode::Singular, 30, 8), 1);   // 4/10
  EXPECT_EQ(rankForBeta(s, 0.7, BetaMode::Singular, 30, 8), 2);   // 7/10 exactly
  EXPECT_EQ(rankForBeta(s, 0.71, BetaMode::Singular, 30, 8), 3);  // 9/10
  EXPECT_EQ(rankForBeta(s, 1.0, BetaMode::Singular, 30, 8), 4);
  EXPECT_EQ(rankForBeta(s, 0.8, BetaMode::Energy, 30, 8), 2);  // 25/30 ≥ 0.8
  EXPECT_EQ(rankForBeta(s, 0.9, BetaMode::Energy, 30, 8), 3);  // 29/30
  EXPECT_EQ(rankForBeta(s, 0.99, BetaMode::Energy, 30, 8), 4);
  EXPECT_EQ(rankForBeta(s, 0.99, BetaMode::Energy, 30, 2), 2);  // capped
  // Energy mode with a truncated spectrum: the Frobenius norm supplies the tail.
  EXPECT_EQ(rankForBeta(s.head(2), 0.8, BetaMode::Energy, 30, 8), 2);
  EXPECT_EQ(rankForBeta(s.head(2), 0.9, BetaMode::Energy, 30, 8), 2);  // can only say 2
  EXPECT_EQ(rankForBeta(VecD::Zero(3), 0.9, BetaMode::Energy, 0, 8), 0);
  // The same spectrum built into a matrix is recovered by both spectra.
  const MatF U = orthonormal(40, 4, 5), V = orthonormal(30, 4, 6);
  const MatF A = U * s.cast<float>().asDiagonal() * V.transpose();
  const VecD all = singularValues(A);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(all[i], s[i], 1e-4);
  EXPECT_NEAR(all[4], 0, 1e-3);
  EXPECT_EQ(rankForBeta(all, 0.71, BetaMode::Singular, 30, 8), 3);
  const Svd t = truncatedSvd(A, 8);
  EXPECT_EQ(rankForBeta(t.s, 0.9, BetaMode::Energy, A.cast<double>().squaredNorm(), 8), 3);
}

TEST(Linalg, NmfStaysNonNegativeWithAMonotoneObjectiveAndDeterministicStart) {
  const MatF A = randomMatrix(64, 48, 77);  // full rank: the factorisation is approximate
  const Svd s = truncatedSvd(A, 6);
  MatF W1, H1, W2, H2;
  nndsvd(s, 6, W1, H1);
  nndsvd(truncatedSvd(A, 6), 6, W2, H2);
  EXPECT_TRUE(W1 == W2 && H1 == H2);  // bitwise identical
  EXPECT_GE(W1.minCoeff(), 0.f);
  EXPECT_GE(H1.minCoeff(), 0.f);
  for (NmfSolver solver : {NmfSolver::Hals, NmfSolver::Multiplicative}) {
    const NmfResult r = nmf(A, 6, s, solver, 200, 0);
    ASSERT_GT(r.objective.size(), 10u);
    EXPECT_GE(r.W.minCoeff(), 0.f);
    EXPECT_GE(r.H.minCoeff(), 0.f);
    for (size_t i = 1; i < r.objective.size(); ++i)
      EXPECT_LE(r.objective[i], r.objective[i - 1] * (1 + 1e-5))
          << nmfSolverName(solver) << " " << i;
    // The recorded objective is the true residual.
    EXPECT_NEAR(r.objective.back(), (A - r.W * r.H).cast<double>().squaredNorm(),
                1e-3 * r.objective.back());
    // And it is no worse than the rank-6 SVD bound by more than a modest factor.
    const double svdErr = A.cast<double>().squaredNorm() - s.s.squaredNorm();
    EXPECT_LT(r.objective.back(), 1.6 * svdErr) << nmfSolverName(solver);
  }
}

TEST(Linalg, HardMatricesGiveNoNanAndSensibleFactors) {
  // All zero: rank 0, empty factors.
  const MatF Z = MatF::Zero(20, 16);
  const Svd sz = truncatedSvd(Z, 4);
  EXPECT_EQ(rankForBeta(sz.s, 0.99, BetaMode::Energy, 0, 4), 0);
  const NmfResult rz = nmf(Z, 2, sz, NmfSolver::Hals, 10, 0);
  EXPECT_EQ(rz.W.cols(), 0);
  // Zero rows and columns (shadowed lights, views below an occluder).
  MatF A = randomMatrix(20, 16, 8);
  A.row(3).setZero();
  A.row(7).setZero();
  A.col(0).setZero();
  A.col(15).setZero();
  const NmfResult ra = nmf(A, 4, truncatedSvd(A, 4), NmfSolver::Hals, 100, 0);
  EXPECT_TRUE(allFinite(ra.W) && allFinite(ra.H));
  const MatF R = ra.W * ra.H;
  EXPECT_LT(R.row(3).norm() + R.row(7).norm() + R.col(0).norm() + R.col(15).norm(), 1e-4);
  // A single non-zero entry: rank 1, exact.
  MatF S = MatF::Zero(12, 9);
  S(5, 4) = 7.5f;
  const NmfResult rs = nmf(S, 1, truncatedSvd(S, 2), NmfSolver::Hals, 10, 0);
  EXPECT_LT(relErr(S, rs.W * rs.H), 1e-6);
  EXPECT_EQ(rankForBeta(truncatedSvd(S, 2).s, 0.999, BetaMode::Energy, 56.25, 8), 1);
  // Huge dynamic range, 1e-6 … 1e3 (a sharp lobe over a dark background).
  MatF D = randomMatrix(32, 32, 9, 1e-6f, 2e-6f);
  for (int i = 0; i < 32; ++i) D(i, i) = 1e3f;
  for (NmfSolver solver : {NmfSolver::Hals, NmfSolver::Multiplicative}) {
    const Svd sd = truncatedSvd(D, 8);
    const NmfResult rd = nmf(D, 8, sd, solver, 100, 1e-6);
    EXPECT_TRUE(allFinite(rd.W) && allFinite(rd.H));
    EXPECT_GE(rd.W.minCoeff(), 0.f);
    // Rank 8 of a diagonal of 32 equal values keeps at most 8/32 of the energy.
    const double e =
        (D - rd.W * rd.H).cast<double>().squaredNorm() / D.cast<double>().squaredNorm();
    EXPECT_LT(e, 1 - 8.0 / 32 + 1e-3) << nmfSolverName(solver);
    EXPECT_TRUE(std::isfinite(e));
  }
}

TEST(Linalg, PcaBasisIsOrthonormalAndAccountsForAllEnergy) {
  const MatF X = randomMatrix(30, 5, 11) * randomMatrix(5, 200, 12);  // rank 5, more samples
  const Basis b = pcaBasis(X, 10);
  EXPECT_EQ(b.B.cols(), 5);  // zero-energy directions are never returned
  EXPECT_LT((b.B.transpose() * b.B - MatF::Identity(5, 5)).norm(), 1e-4);
  EXPECT_NEAR(b.eigen.sum(), b.total, 1e-4 * b.total);
  EXPECT_LT(relErr(X, b.B * (b.B.transpose() * X)), 1e-5);
  EXPECT_EQ(componentsForResidual(b, 0.0), 5);
  const Basis few = pcaBasis(X.leftCols(3), 10);  // fewer samples than dimensions
  EXPECT_EQ(few.B.cols(), 3);
  EXPECT_LT(relErr(X.leftCols(3), few.B * (few.B.transpose() * X.leftCols(3))), 1e-5);
}

TEST(Linalg, HalfFloatsRoundToNearestEvenAndSaturate) {
  for (float v : {0.f, 1.f, -2.f, 0.5f, 65504.f, 6.103515625e-05f, 5.9604645e-08f, 1024.5f})
    EXPECT_EQ(halfToFloat(floatToHalf(v)), v == 1024.5f ? 1024.f : v) << v;  // 1024.5 → even
  EXPECT_EQ(halfToFloat(floatToHalf(1025.5f)), 1026.f);
  EXPECT_EQ(halfToFloat(floatToHalf(1e6f)), 65504.f);
  EXPECT_EQ(halfToFloat(floatToHalf(-1e6f)), -65504.f);
  EXPECT_EQ(halfToFloat(floatToHalf(std::nanf(""))), 0.f);
  EXPECT_EQ(halfToFloat(floatToHalf(1e-9f)), 0.f);
  // Relative error bound 2^-11 over the normal range.
  Rng rng(5);
  for (int i = 0; i < 10000; ++i) {
    const float v = std::exp(uniformFloat(rng.next()) * 20.f - 9.f);
    EXPECT_LE(std::abs(halfToFloat(floatToHalf(v)) - v), v * 4.9e-4f) << v;
  }
}
