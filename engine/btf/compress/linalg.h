// Dense linear algebra of the compressors (docs/compression.md): truncated SVD by randomized
// subspace iteration, the β rank rule of eq. 3.21, NNDSVD initialisation (Boutsidis &
// Gallopoulos 2008), non-negative matrix factorisation (HALS or Lee–Seung multiplicative
// updates), PCA bases from samples, and IEEE half floats. Float matrices (Eigen, column-major);
// spectra and objectives are accumulated in double.
#pragma once
#include <Eigen/Dense>
#include <cstdint>
#include <string>
#include <vector>

namespace btf::la {

using MatF = Eigen::MatrixXf;
using VecF = Eigen::VectorXf;
using VecD = Eigen::VectorXd;

/// A ≈ U · diag(s) · Vᵀ with s descending, U (m × r), V (n × r) orthonormal columns.
struct Svd {
  VecD s;
  MatF U, V;
};

/// The top-r singular triplets by randomized subspace iteration (Halko, Martinsson & Tropp
/// 2011) with a fixed seed (deterministic). r is clamped to min(m, n).
Svd truncatedSvd(const MatF& A, int r, int powerIterations = 2, uint64_t seed = 1);
/// Every singular value of A (from the eigenvalues of the smaller Gram matrix), descending.
VecD singularValues(const MatF& A);

/// β rank rule. Singular: the smallest k with Σ_{i≤k} σ_i ≥ β Σ σ_i (eq. 3.21; needs the full
/// spectrum). Energy: the smallest k with Σ_{i≤k} σ_i² ≥ β ‖A‖²_F (exact from a truncated
/// spectrum, and 1 − β is the relative squared error of the rank-k truncation). Returns 0 for a
/// zero spectrum and at most kmax.
enum class BetaMode { Singular, Energy };
int rankForBeta(const VecD& s, double beta, BetaMode mode, double frobenius2, int kmax);
BetaMode betaModeFromName(const std::string& name);
std::string betaModeName(BetaMode m);

/// NNDSVD (Boutsidis & Gallopoulos): non-negative W (m × k), H (k × n) from the top k singular
/// triplets. Zeros stay zero (HALS can revive them); `fill` > 0 replaces them by fill (the
/// "NNDSVDa"-style start that multiplicative updates need).
void nndsvd(const Svd& svd, int k, MatF& W, MatF& H, float fill = 0.f);

enum class NmfSolver { Hals, Multiplicative };
NmfSolver nmfSolverFromName(const std::string& name);
std::string nmfSolverName(NmfSolver s);

struct NmfResult {
  MatF W, H;                      // A ≈ W H, both ≥ 0
  std::vector<double> objective;  // ‖A − W H‖²_F after each H update (never increases)
  int iterations = 0;
};
/// Factorises A ≥ 0 from NNDSVD of `svd` (its first k triplets). Stops after maxIterations or
/// when an iteration lowers the objective by less than tol (relative).
NmfResult nmf(const MatF& A, int k, const Svd& svd, NmfSolver solver, int maxIterations,
              double tol);

/// Uncentred PCA of the columns of X (dim × n): the top-c unit eigenvectors of X Xᵀ (dim × c)
/// and every eigenvalue (descending; they sum to ‖X‖²_F). Works on the smaller Gram matrix;
/// columns of zero energy are never returned (c shrinks).
struct Basis {
  MatF B;
  VecD eigen;
  double total = 0;  // ‖X‖²_F
};
Basis pcaBasis(const MatF& X, int c);
/// The same from the samples' Gram matrix G = X Xᵀ (dim × dim, symmetric): total = trace(G).
Basis pcaBasisFromGram(const Eigen::MatrixXd& G, int c);
/// Smallest c whose retained energy leaves at most `residual` (fraction of total) unexplained.
int componentsForResidual(const Basis& b, double residual);

/// X (n × d)ᵀ X over row blocks in parallel (TBB), accumulated in double, result d × d.
Eigen::MatrixXd gramOfColumns(const MatF& X);

/// IEEE 754 binary16, round to nearest even; overflow saturates to ±65504, NaN maps to 0.
uint16_t floatToHalf(float f);
float halfToFloat(uint16_t h);

}  // namespace btf::la
