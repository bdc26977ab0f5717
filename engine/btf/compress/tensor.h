// The tensor codec's linear algebra (docs/compression.md, "tensor"): IRP k-means on nested
// sign sketches, and the Tucker (HOSVD / HOOI) factorisation of a views × lights × texels
// tensor given as its texel slices. Spectra and errors are accumulated in double.
#pragma once
#include <btf/compress/linalg.h>

#include <cstdint>
#include <vector>

namespace btf::la {

/// A count sketch (Charikar, Chen & Farach-Colton; a sparse random projection): input index i
/// adds sign(i) · x_i to output h(i) mod D, with (h, sign) hashed from (seed, i). D is a power of
/// two, so folding a D-sketch modulo d | D gives the d-sketch of the same input: the nested
/// projections of IRP k-means cost one pass over the data.
class SignSketch {
 public:
  static constexpr int kMaxDim = 1024;
  SignSketch(int64_t inputDim, int outputDim, uint64_t seed);
  int dim() const { return m_d; }
  int64_t inputDim() const { return int64_t(m_code.size()); }
  /// out[0..dim) = sketch of x[0..inputDim).
  void apply(const float* x, float* out) const;

 private:
  int m_d;
  std::vector<uint16_t> m_code;  // bucket (low 15 bits) and sign (bit 15)
};

/// Sums the columns' coordinates modulo d (d divides rows): the d-dimensional sketch of every
/// column from its D-dimensional one.
MatF foldSketch(const MatF& X, int d);

struct KMeansResult {
  MatF centres;             // D × K, in the full sketch space
  std::vector<int> assign;  // per column of the data
  std::vector<int> dims;    // the projection dimensions visited
  int iterations = 0;       // Lloyd iterations, all dimensions together
  int reseeds = 0;          // empty clusters given the farthest point
};

/// IRP k-means (Cardoso & Wichert 2012, iterative random projections): k-means++ seeding and
/// Lloyd iterations in a 2-dimensional fold of the sketches, then in folds of growing dimension
/// (4, 8, … D), each started from the previous assignment. X: D × n sketches. Deterministic for a
/// seed. K is clamped to n.
KMeansResult irpKMeans(const MatF& X, int K, uint64_t seed, int maxIterations = 30);
/// Index of the nearest centre (squared distance; lowest index on ties).
int nearestCentre(const MatF& centres, const float* x);

/// A Tucker model of the tensor whose texel slices are A_i (nV × nL): the orthonormal view and
/// light bases, the texel factors (m × Rt, orthonormal) and the core in "texel-slice" form:
/// coreSlices[c] = Σ_i Ut(i, c) · Uvᵀ A_i Ul (Rv × Rl).
struct Tucker3 {
  MatF Uv, Ul, Ut;
  std::vector<MatF> coreSlices;
  double energy = 0;  // Σ ‖A_i‖²
  double error = 0;  // Σ ‖A_i − Â_i‖² (= energy − ‖core‖², the bases being orthonormal)
};

/// The eigenvalues (descending, clamped ≥ 0) and eigenvectors of a symmetric matrix.
void symmetricEigen(const Eigen::MatrixXd& G, VecD& values, Eigen::MatrixXd& vectors);

/// Mode spectra of the slices: eigenvalues of Σ A_i A_iᵀ (views), Σ A_iᵀ A_i (lights) and of the
/// texels' Gram matrix ⟨A_i, A_j⟩; each sums to Σ ‖A_i‖². The error of a Tucker model with ranks
/// (Rv, Rl, Rt) is at most the sum of the three tails (the HOSVD bound).
struct ModeSpectra {
  VecD view, light, texel;
  MatF viewVectors, lightVectors;  // the leading eigenvectors (at most keepVectors columns)
  double energy = 0;
};
ModeSpectra modeSpectra(const std::vector<const MatF*>& slices, int keepVectors = 0);

/// HOSVD initialisation then `sweeps` HOOI sweeps (each mode updated as the top singular vectors
/// of the tensor projected on the two others). errors, when given, receives the error after the
/// initialisation and after every sweep (never increasing). Ranks are clamped to the tensor.
/// `start`, when given, supplies the HOSVD bases (its leading eigenvectors; it must hold at least
/// Rv and Rl of them) instead of recomputing the two mode Gram matrices.
Tucker3 hooi(const std::vector<const MatF*>& slices, int Rv, int Rl, int Rt, int sweeps,
             std::vector<double>* errors = nullptr, const ModeSpectra* start = nullptr);

}  // namespace btf::la
