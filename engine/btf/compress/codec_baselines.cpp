// The classic BTF codecs of §3.3.2 on the same data, behind the same interface. Each fits its
// bases on a stratified training subset of texels (so streaming from the simulator and
// compressing a stored BTF give identical files), then projects every texel.
//
// svd (full-matrix factorisation, Bonn's DFMF): per channel c, c{c}.basis (nV·nL × C, row
//   v·nL + l) and c{c}.coef (texels × C): value_c(t, v, l) = Σ_k basis[v·nL + l, k] coef[t, k].
// perview (Sattler et al. 2003, per-view PCA): c{c}.basis (nV·nL × C, rows of view v are its
//   basis over lights) and c{c}.coef (texels × nV·C): value_c = Σ_k basis[v·nL + l, k]
//   coef[t, v·C + k].
// lpca (Müller et al. 2003, clustered local PCA): texels clustered by k-means (k-means++ seeds)
//   on their global-SVD coordinates; per cluster m and channel c a basis: c{c}.basis
//   (K·nV·nL × C, row m·nV·nL + v·nL + l); cluster (texels × 1); c{c}.coef (texels × C).
#include <btf/core/error.h>
#include <btf/core/rng.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>

#include "codec.h"

namespace btf {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Shared: training values per channel as a (nV·nL) × nTrain matrix.
class TrainedEncoder : public Encoder {
 public:
  TrainedEncoder(const CodecSettings& s, const BtfInfo& info, const CancelToken* cancel)
      : m_s(s),
        m_info(info),
        m_cancel(cancel),
        m_n(info.nDirs()),
        m_lv(int64_t(info.nDirs()) * info.nDirs()) {
    m_train = stratifiedTexels(info.nu, info.nv, s.trainTexels, s.seed);
    m_done.assign(size_t(info.texels()), 0);
  }
  std::vector<int64_t> trainingTexels() const override { return m_train; }
  void train(const float* values) override {
    const auto start = Clock::now();
    for (int c = 0; c < 3; ++c) m_X[c].resize(m_lv, int64_t(m_train.size()));
    const size_t stride = size_t(m_lv) * 3;
    parallelForChunks(int64_t(m_train.size()), 1, [&](int64_t b, int64_t e) {
      for (int64_t i = b; i < e; ++i)
        for (int64_t k = 0; k < m_lv; ++k) {
          float col[3];
          toColour(m_s.colour, values + size_t(i) * stride + size_t(k) * 3, col);
          for (int c = 0; c < 3; ++c) m_X[c](k, i) = col[c];
        }
    });
    double total = 0;
    for (int c = 0; c < 3; ++c) total += m_X[c].cast<double>().squaredNorm();
    m_trainEnergy = total;
    fit();
    for (auto& x : m_X) x.resize(0, 0);  // training data no longer needed
    m_trained = true;
    m_trainSeconds = since(start);
  }
  void add(int64_t t0, int64_t t1, const float* values) override {
    if (!m_trained) throw Error(m_s.codec + " encoder: add() before train()");
    const auto start = Clock::now();
    const size_t stride = size_t(m_lv) * 3;
    // Blocks of texels as per-channel matrices (lv × block): projections become GEMMs, so each
    // basis is read once per block rather than once per texel.
    const int64_t block = 32;
    const int64_t nb = (t1 - t0 + block - 1) / block;
    parallelForChunks(
        nb, 1,
        [&](int64_t b0, int64_t b1) {
          la::MatF X[3];
          for (int64_t bi = b0; bi < b1; ++bi) {
            const int64_t s0 = bi * block, s1 = std::min(t1 - t0, s0 + block);
            // Always `block` columns (zero padded): Eigen's GEMM blocking depends on the matrix
            // sizes, so a fixed size keeps every texel's coefficients bitwise independent of
            // how the stream was chunked.
            for (auto& x : X) x.setZero(m_lv, block);
            for (int64_t i = s0; i < s1; ++i) {
              const float* x = values + size_t(i) * stride;
              for (int64_t k = 0; k < m_lv; ++k) {
                float col[3];
                toColour(m_s.colour, x + size_t(k) * 3, col);
                X[0](k, i - s0) = col[0], X[1](k, i - s0) = col[1], X[2](k, i - s0) = col[2];
              }
            }
            encodeBlock(t0 + s0, s1 - s0, X);
            for (int64_t i = s0; i < s1; ++i) m_done[size_t(t0 + i)] = 1;
          }
        },
        m_cancel);
    m_encodeSeconds += since(start);
  }
  // The per-texel rows of the coefficient (and cluster) arrays.
  std::string addedState() const override {
    StateWriter w;
    for (int64_t t = 0; t < int64_t(m_done.size()); ++t) {
      if (!m_done[size_t(t)]) continue;
      w.put<int64_t>(t);
      for (const CArray* a : m_texelArrays)
        w.putVector(std::vector<float>(a->data.begin() + ptrdiff_t(size_t(t) * a->cols),
                                       a->data.begin() + ptrdiff_t(size_t(t + 1) * a->cols)));
    }
    return w.take();
  }
  void mergeAdded(const std::string& bytes) override {
    if (!m_trained) throw Error(m_s.codec + " encoder: mergeAdded() before train()");
    StateReader r(bytes);
    while (!r.done()) {
      const int64_t t = r.get<int64_t>();
      if (t < 0 || t >= int64_t(m_done.size())) throw Error("encoder state: texel out of range");
      for (CArray* a : m_texelArrays) {
        const std::vector<float> row = r.getVector<float>(uint64_t(a->cols));
        if (row.size() != size_t(a->cols)) throw Error("encoder state: row size mismatch");
        std::copy(row.begin(), row.end(), a->data.begin() + ptrdiff_t(size_t(t) * a->cols));
      }
      m_done[size_t(t)] = 1;
    }
  }

  CompressedBtf finish() override {
    for (size_t t = 0; t < m_done.size(); ++t)
      if (!m_done[t])
        throw Error(m_s.codec + " encoder: texel " + std::to_string(t) + " was never added");
    m_out.info = m_info;
    m_out.codec = m_s.codec;
    m_out.colour = m_s.colour;
    m_out.quantize();
    nlohmann::ordered_json params = nlohmann::ordered_json::parse(settingsJson(m_s));
    params["components_per_channel"] = {m_C[0], m_C[1], m_C[2]};
    params["training_texels"] = m_train.size();
    extraParams(params);
    m_out.paramsJson = params.dump();
    nlohmann::ordered_json st;
    // No timings in the file: the same request writes the same bytes (timings are in reports).
    st["training_relative_rmse"] = m_trainRel;
    m_out.statsJson = st.dump();
    return std::move(m_out);
  }

 protected:
  virtual void fit() = 0;
  /// Texels [t0, t0 + count), one column each of X[c] (extra columns are zero padding).
  virtual void encodeBlock(int64_t t0, int64_t count, const la::MatF X[3]) = 0;
  virtual void extraParams(nlohmann::ordered_json&) const {}
  ArrayType type() const { return m_s.half ? ArrayType::F16 : ArrayType::F32; }
  double rawBytes() const { return double(m_info.texels()) * double(m_lv) * 12.0; }
  int scalarBytes() const { return m_s.half ? 2 : 4; }

  /// Components per channel from the settings: explicit, ratio (size model bytesOf(C) for all
  /// three channels), or residual energy (target relative RMSE; default 5 %) of the spectra.
  void chooseComponents(const la::Basis* spectra, int maxC,
                        const std::function<double(int)>& bytesOf) {
    const int C = m_s.components;
    if (C > 0) {
      for (int c = 0; c < 3; ++c) m_C[c] = std::min<int>(C, int(spectra[c].B.cols()));
      return;
    }
    // Greedy over the three channels: keep the largest remaining eigenvalue until the size model
    // no longer fits raw/ratio, or (error target) the unexplained energy is ≤ target² · total.
    const bool byRatio = m_s.targetRatio > 0;
    const double cost = (bytesOf(2) - bytesOf(1)) / 3, fixed = bytesOf(1) - 3 * cost;
    double budget =
        byRatio ? rawBytes() / m_s.targetRatio - 65536.0 - fixed - double(m_reservedBytes) : 0;
    const double target = m_s.targetRmse > 0 ? m_s.targetRmse : 0.05;
    double total = 0;
    for (int c = 0; c < 3; ++c) total += spectra[c].total;
    double left = total;
    int idx[3] = {0, 0, 0};
    while (byRatio ? budget >= cost : left > target * target * total) {
      int best = -1;
      double bv = 0;
      for (int c = 0; c < 3; ++c)
        if (idx[c] < std::min<int>(maxC, int(spectra[c].B.cols())) && spectra[c].eigen[idx[c]] > bv)
          bv = spectra[c].eigen[idx[c]], best = c;
      if (best < 0) break;
      ++idx[best];
      left -= bv;
      budget -= cost;
    }
    for (int c = 0; c < 3; ++c) m_C[c] = idx[c];
  }

  CodecSettings m_s;
  BtfInfo m_info;
  const CancelToken* m_cancel;
  int m_n;
  int64_t m_lv;
  std::vector<int64_t> m_train;
  std::vector<uint8_t> m_done;
  la::MatF m_X[3];
  double m_trainEnergy = 0, m_trainRel = 0;
  bool m_trained = false;
  double m_trainSeconds = 0, m_encodeSeconds = 0;
  int m_C[3] = {0, 0, 0};
  CompressedBtf m_out;
  std::vector<CArray*> m_texelArrays;  // arrays with one row per texel (addedState)
};

// Stores B (rows × C) in an array region and returns the quantized copy used for projection.
la::MatF storeBasis(CArray& a, int64_t row0, const la::MatF& B) {
  la::MatF Q(B.rows(), B.cols());
  for (int64_t i = 0; i < B.rows(); ++i)
    for (int64_t k = 0; k < B.cols(); ++k) {
      float v = B(i, k);
      if (a.type == ArrayType::F16) v = la::halfToFloat(la::floatToHalf(v));
      a.data[size_t((row0 + i) * a.cols + k)] = v;
      Q(i, k) = v;
    }
  return Q;
}

la::MatF gramInverse(const la::MatF& B) {
  if (B.cols() == 0) return la::MatF(0, 0);
  return (B.transpose() * B).ldlt().solve(la::MatF::Identity(B.cols(), B.cols()));
}

// Several bases that share one component count (per view, per cluster): their spectra summed
// by rank position, so the k-th components of all of them are kept or dropped together. Only
// the eigenvalues, the total and the column count (B is empty) are filled.
la::Basis mergeSpectra(const std::vector<la::Basis>& b, size_t first, int count, int maxC) {
  la::Basis m;
  m.eigen = la::VecD::Zero(maxC);
  int cols = 0;
  for (int i = 0; i < count; ++i) {
    const la::Basis& x = b[first + size_t(i)];
    m.total += x.total;
    for (int k = 0; k < std::min<int>(maxC, int(x.eigen.size())); ++k) m.eigen[k] += x.eigen[k];
    cols = std::max(cols, int(x.B.cols()));
  }
  m.B.resize(0, cols);
  return m;
}

// ------------------------------------------------------------------ svd

class SvdEncoder final : public TrainedEncoder {
 public:
  using TrainedEncoder::TrainedEncoder;
  uint64_t memoryBytes() const override {
    const int C = std::max(64, m_s.components);
    return uint64_t(m_lv) * (uint64_t(m_train.size()) + uint64_t(C)) * 3 * 4 +
           uint64_t(m_info.texels()) * uint64_t(C) * 3 * 4;
  }

 protected:
  void fit() override {
    la::Basis b[3];
    const int maxC = int(m_train.size());
    for (int c = 0; c < 3; ++c) b[c] = la::pcaBasis(m_X[c], maxC);
    chooseComponents(b, maxC, [&](int C) {
      return 3.0 * (double(m_lv) * C + double(m_info.texels()) * C) * scalarBytes();
    });
    double kept = 0;
    for (int c = 0; c < 3; ++c) {
      CArray& a = m_out.add(channelArray(c, "basis"), type(), m_lv, m_C[c]);
      m_B[c] = storeBasis(a, 0, b[c].B.leftCols(m_C[c]));
      m_G[c] = gramInverse(m_B[c]);
      for (int k = 0; k < m_C[c]; ++k) kept += b[c].eigen[k];
      m_coef[c] = &m_out.add(channelArray(c, "coef"), type(), m_info.texels(), m_C[c]);
      m_texelArrays.push_back(m_coef[c]);
    }
    m_trainRel = m_trainEnergy > 0 ? std::sqrt(std::max(0.0, 1 - kept / m_trainEnergy)) : 0;
  }
  void encodeBlock(int64_t t0, int64_t count, const la::MatF X[3]) override {
    for (int c = 0; c < 3; ++c) {
      if (m_C[c] == 0) continue;
      const la::MatF K = m_G[c] * (m_B[c].transpose() * X[c]);  // C × block
      for (int64_t i = 0; i < count; ++i)
        for (int q = 0; q < m_C[c]; ++q) m_coef[c]->data[size_t((t0 + i) * m_C[c] + q)] = K(q, i);
    }
  }

 private:
  la::MatF m_B[3], m_G[3];
  CArray* m_coef[3] = {nullptr, nullptr, nullptr};
};

// ------------------------------------------------------------------ perview

class PerViewEncoder final : public TrainedEncoder {
 public:
  using TrainedEncoder::TrainedEncoder;
  uint64_t memoryBytes() const override {
    const int C = std::max(16, m_s.components);
    return uint64_t(m_lv) * (uint64_t(m_train.size()) + uint64_t(C)) * 3 * 4 +
           uint64_t(m_info.texels()) * uint64_t(m_n) * uint64_t(C) * 3 * 4;
  }

 protected:
  void fit() override {
    // Per channel and view: basis over lights from the training texels' rows of that view.
    const int maxC = std::min<int>(int(m_train.size()), m_n);
    std::vector<la::Basis> b(size_t(3) * m_n);
    parallelForChunks(int64_t(3) * m_n, 1, [&](int64_t i0, int64_t i1) {
      for (int64_t i = i0; i < i1; ++i) {
        const int c = int(i / m_n), v = int(i % m_n);
        b[size_t(i)] = la::pcaBasis(m_X[c].middleRows(int64_t(v) * m_n, m_n), maxC);
      }
    });
    // One C for all views of a channel (fixed layout).
    la::Basis merged[3];
    for (int c = 0; c < 3; ++c) merged[c] = mergeSpectra(b, size_t(c) * m_n, m_n, maxC);
    chooseComponents(merged, maxC, [&](int C) {
      return 3.0 * (double(m_lv) * C + double(m_info.texels()) * m_n * C) * scalarBytes();
    });
    double kept = 0;
    for (int c = 0; c < 3; ++c) {
      CArray& a = m_out.add(channelArray(c, "basis"), type(), m_lv, m_C[c]);
      m_B[c].resize(size_t(m_n));
      m_G[c].resize(size_t(m_n));
      for (int v = 0; v < m_n; ++v) {
        const la::Basis& bv = b[size_t(c) * m_n + v];
        la::MatF B = la::MatF::Zero(m_n, m_C[c]);
        const int have = std::min<int>(m_C[c], int(bv.B.cols()));
        B.leftCols(have) = bv.B.leftCols(have);
        for (int k = 0; k < have; ++k) kept += bv.eigen[k];
        m_B[c][size_t(v)] = storeBasis(a, int64_t(v) * m_n, B);
        m_G[c][size_t(v)] = gramInverse(m_B[c][size_t(v)].leftCols(have));
        m_have[c].push_back(have);
      }
      m_coef[c] =
          &m_out.add(channelArray(c, "coef"), type(), m_info.texels(), int64_t(m_n) * m_C[c]);
      m_texelArrays.push_back(m_coef[c]);
    }
    m_trainRel = m_trainEnergy > 0 ? std::sqrt(std::max(0.0, 1 - kept / m_trainEnergy)) : 0;
  }
  void encodeBlock(int64_t t0, int64_t count, const la::MatF X[3]) override {
    for (int c = 0; c < 3; ++c) {
      const int C = m_C[c];
      if (C == 0) continue;
      for (int v = 0; v < m_n; ++v) {
        const int have = m_have[c][size_t(v)];
        if (have == 0) continue;
        const la::MatF K = m_G[c][size_t(v)] * (m_B[c][size_t(v)].leftCols(have).transpose() *
                                                X[c].middleRows(int64_t(v) * m_n, m_n));
        for (int64_t i = 0; i < count; ++i) {
          float* dst = m_coef[c]->data.data() + size_t(t0 + i) * m_coef[c]->cols + size_t(v) * C;
          for (int q = 0; q < have; ++q) dst[q] = K(q, i);
        }
      }
    }
  }

 private:
  std::vector<la::MatF> m_B[3], m_G[3];
  std::vector<int> m_have[3];
  CArray* m_coef[3] = {nullptr, nullptr, nullptr};
};

// ------------------------------------------------------------------ lpca

class LpcaEncoder final : public TrainedEncoder {
 public:
  LpcaEncoder(const CodecSettings& s, const BtfInfo& info, const CancelToken* cancel)
      : TrainedEncoder(adjusted(s), info, cancel) {}
  uint64_t memoryBytes() const override {
    const int C = std::max(8, m_s.components);
    return uint64_t(m_lv) * (uint64_t(m_train.size()) + uint64_t(C * m_s.clusters)) * 3 * 4 +
           uint64_t(m_info.texels()) * uint64_t(C) * 3 * 4;
  }

 protected:
  static CodecSettings adjusted(CodecSettings s) {
    if (s.clusters == 0) s.clusters = 8;
    // Enough training texels for every cluster to get a basis.
    s.trainTexels = std::max(s.trainTexels, 16 * s.clusters);
    return s;
  }
  void fit() override {
    const int n = int(m_train.size());
    const int K = std::min(m_s.clusters, n);
    // Features: coordinates on a small global basis per channel.
    const int F = std::min(8, n);
    int64_t fdim = 0;
    for (int c = 0; c < 3; ++c) {
      m_F[c] = la::pcaBasis(m_X[c], F).B;
      fdim += m_F[c].cols();
    }
    la::MatF feat(fdim, n);
    for (int i = 0; i < n; ++i) feat.col(i) = features(m_X, i);
    // k-means++ seeding (deterministic stream), then Lloyd iterations; an empty cluster takes
    // the point farthest from its centre.
    Rng rng(m_s.seed * 0x9e3779b97f4a7c15ULL + 17);
    la::MatF cent(fdim, K);
    std::vector<double> d2(size_t(n), std::numeric_limits<double>::max());
    int first = int(rng.next() % uint64_t(n));
    cent.col(0) = feat.col(first);
    for (int k = 1; k < K; ++k) {
      double sum = 0;
      for (int i = 0; i < n; ++i) {
        d2[size_t(i)] =
            std::min(d2[size_t(i)], double((feat.col(i) - cent.col(k - 1)).squaredNorm()));
        sum += d2[size_t(i)];
      }
      double r = uniformFloat(rng.next()) * sum;
      int pick = n - 1;
      for (int i = 0; i < n; ++i) {
        r -= d2[size_t(i)];
        if (r <= 0) {
          pick = i;
          break;
        }
      }
      cent.col(k) = feat.col(pick);
    }
    std::vector<int> assign(size_t(n), 0);
    for (int it = 0; it < 30; ++it) {
      bool changed = false;
      for (int i = 0; i < n; ++i) {
        const int a = nearest(cent, feat.col(i));
        if (a != assign[size_t(i)]) changed = true;
        assign[size_t(i)] = a;
      }
      la::MatF sum = la::MatF::Zero(fdim, K);
      std::vector<int> count(size_t(K), 0);
      for (int i = 0; i < n; ++i) {
        sum.col(assign[size_t(i)]) += feat.col(i);
        count[size_t(assign[size_t(i)])]++;
      }
      for (int k = 0; k < K; ++k) {
        if (count[size_t(k)] > 0) {
          cent.col(k) = sum.col(k) / float(count[size_t(k)]);
        } else {
          int far = 0;
          double best = -1;
          for (int i = 0; i < n; ++i) {
            const double d = (feat.col(i) - cent.col(assign[size_t(i)])).squaredNorm();
            if (d > best) best = d, far = i;
          }
          cent.col(k) = feat.col(far);
          assign[size_t(far)] = k;
          changed = true;
          ++m_emptyReseeds;
        }
      }
      if (!changed && it > 0) break;
    }
    m_cent = cent;
    // Per cluster and channel bases from the members.
    std::vector<std::vector<int>> members{size_t(K)};
    for (int i = 0; i < n; ++i) members[size_t(assign[size_t(i)])].push_back(i);
    std::vector<la::Basis> b(size_t(3) * K);
    int maxC = 1;
    for (int k = 0; k < K; ++k) {
      maxC = std::max<int>(maxC, int(members[size_t(k)].size()));
      for (int c = 0; c < 3; ++c) {
        la::MatF Xk(m_lv, int64_t(members[size_t(k)].size()));
        for (size_t j = 0; j < members[size_t(k)].size(); ++j)
          Xk.col(int64_t(j)) = m_X[c].col(members[size_t(k)][j]);
        b[size_t(c) * K + k] = la::pcaBasis(Xk, int(members[size_t(k)].size()));
      }
    }
    la::Basis merged[3];
    for (int c = 0; c < 3; ++c) merged[c] = mergeSpectra(b, size_t(c) * K, K, maxC);
    chooseComponents(merged, maxC, [&](int C) {
      return 3.0 * (double(K) * m_lv * C + double(m_info.texels()) * C) * scalarBytes() +
             double(m_info.texels()) * scalarBytes();
    });
    double kept = 0;
    m_cluster = &m_out.add("cluster", ArrayType::F32, m_info.texels(), 1);
    m_texelArrays.push_back(m_cluster);
    for (int c = 0; c < 3; ++c) {
      CArray& a = m_out.add(channelArray(c, "basis"), type(), int64_t(K) * m_lv, m_C[c]);
      for (int k = 0; k < K; ++k) {
        const la::Basis& bk = b[size_t(c) * K + k];
        const int have = std::min<int>(m_C[c], int(bk.B.cols()));
        la::MatF B = la::MatF::Zero(m_lv, m_C[c]);
        B.leftCols(have) = bk.B.leftCols(have);
        for (int q = 0; q < have; ++q) kept += bk.eigen[q];
        m_B[c].push_back(storeBasis(a, int64_t(k) * m_lv, B));
        m_G[c].push_back(gramInverse(m_B[c].back().leftCols(have)));
        m_have[c].push_back(have);
      }
      m_coef[c] = &m_out.add(channelArray(c, "coef"), type(), m_info.texels(), m_C[c]);
      m_texelArrays.push_back(m_coef[c]);
    }
    m_K = K;
    m_trainRel = m_trainEnergy > 0 ? std::sqrt(std::max(0.0, 1 - kept / m_trainEnergy)) : 0;
  }
  void encodeBlock(int64_t t0, int64_t count, const la::MatF X[3]) override {
    const int64_t n = count;
    std::vector<std::vector<int64_t>> groups{size_t(m_K)};
    for (int64_t i = 0; i < n; ++i) {
      const int k = nearest(m_cent, features(X, int(i)));
      m_cluster->data[size_t(t0 + i)] = float(k);
      groups[size_t(k)].push_back(i);
    }
    for (int k = 0; k < m_K; ++k) {
      const auto& g = groups[size_t(k)];
      if (g.empty()) continue;
      for (int c = 0; c < 3; ++c) {
        const int have = m_have[c][size_t(k)];
        if (have == 0) continue;
        la::MatF Xg = la::MatF::Zero(m_lv, X[c].cols());  // fixed size: see add()
        for (size_t j = 0; j < g.size(); ++j) Xg.col(int64_t(j)) = X[c].col(g[j]);
        const la::MatF Q = m_G[c][size_t(k)] * (m_B[c][size_t(k)].leftCols(have).transpose() * Xg);
        for (size_t j = 0; j < g.size(); ++j)
          for (int i = 0; i < have; ++i)
            m_coef[c]->data[size_t((t0 + g[j]) * m_C[c] + i)] = Q(i, int64_t(j));
      }
    }
  }
  void extraParams(nlohmann::ordered_json& j) const override {
    j["clusters_used"] = m_K;
    j["empty_cluster_reseeds"] = m_emptyReseeds;
  }

 private:
  la::VecF features(const la::MatF X[3], int col) const {
    int64_t d = 0;
    for (int c = 0; c < 3; ++c) d += m_F[c].cols();
    la::VecF f(d);
    int64_t o = 0;
    for (int c = 0; c < 3; ++c) {
      if (m_F[c].cols() == 0) continue;
      f.segment(o, m_F[c].cols()) = m_F[c].transpose() * X[c].col(col);
      o += m_F[c].cols();
    }
    return f;
  }
  static int nearest(const la::MatF& cent, const la::VecF& f) {
    int best = 0;
    double bd = std::numeric_limits<double>::max();
    for (int k = 0; k < cent.cols(); ++k) {
      const double d = (cent.col(k) - f).squaredNorm();
      if (d < bd) bd = d, best = k;
    }
    return best;
  }
  la::MatF m_F[3], m_cent;
  std::vector<la::MatF> m_B[3], m_G[3];
  std::vector<int> m_have[3];
  CArray* m_coef[3] = {nullptr, nullptr, nullptr};
  CArray* m_cluster = nullptr;
  int m_K = 0, m_emptyReseeds = 0;
};

// ------------------------------------------------------------------ decoders

class LinearDecoder final : public Decoder {
 public:
  explicit LinearDecoder(CompressedBtf c) : Decoder(c.info), m_c(std::move(c)) {
    m_n = m_info.nDirs();
    m_lv = int64_t(m_n) * m_n;
    m_mode = m_c.codec == "svd" ? 0 : m_c.codec == "perview" ? 1 : 2;
    if (m_mode == 2) {
      m_cluster = &m_c.array("cluster");
      if (m_cluster->rows != m_info.texels() || m_cluster->cols != 1)
        throw Error("compressed BTF (lpca): the cluster array is " +
                    std::to_string(m_cluster->rows) + " × " + std::to_string(m_cluster->cols) +
                    ", expected " + std::to_string(m_info.texels()) + " × 1");
    }
    for (int ch = 0; ch < 3; ++ch) {
      m_b[ch] = &m_c.array(channelArray(ch, "basis"));
      m_k[ch] = &m_c.array(channelArray(ch, "coef"));
      const int64_t C = m_b[ch]->cols;
      const int64_t expectCols = m_mode == 1 ? int64_t(m_n) * C : C;
      const int64_t K = m_mode == 2 ? (m_lv ? m_b[ch]->rows / m_lv : 0) : 1;
      if (m_b[ch]->rows != K * m_lv || m_k[ch]->rows != m_info.texels() ||
          m_k[ch]->cols != expectCols)
        throw Error("compressed BTF (" + m_c.codec + "): channel " + std::to_string(ch) +
                    " arrays have inconsistent dimensions");
      if (m_mode == 2 && ch > 0 && K != m_clusters)
        throw Error("compressed BTF (lpca): channels have different cluster counts");
      m_clusters = int(K);
    }
    // Every texel's cluster, once: an integer within the clusters (a NaN or a fraction in a
    // damaged file would index outside the bases).
    if (m_mode == 2)
      for (int64_t t = 0; t < m_info.texels(); ++t) {
        const float k = m_cluster->data[size_t(t)];
        if (!(k >= 0 && k < float(m_clusters) && k == std::floor(k)))
          throw Error("compressed BTF (lpca): texel " + std::to_string(t) + " names cluster " +
                      std::to_string(k) + " of " + std::to_string(m_clusters));
      }
  }
  std::string kind() const override { return m_c.codec; }

  void texel(int64_t t, float* out) const override {
    const int64_t base = m_mode == 2 ? clusterOf(t) * m_lv : 0;
    for (int64_t k = 0; k < m_lv; ++k) {
      float in[3];
      for (int ch = 0; ch < 3; ++ch) in[ch] = dot(ch, t, base, k);
      fromColour(m_c.colour, in, out + size_t(k) * 3);
    }
  }
  std::array<float, 3> value(int64_t t, int view, int light) const override {
    const int64_t base = m_mode == 2 ? clusterOf(t) * m_lv : 0;
    const int64_t k = int64_t(view) * m_n + light;
    float in[3];
    for (int ch = 0; ch < 3; ++ch) in[ch] = dot(ch, t, base, k);
    std::array<float, 3> rgb{};
    fromColour(m_c.colour, in, rgb.data());
    return rgb;
  }

 private:
  int64_t clusterOf(int64_t t) const {
    const int64_t k = int64_t(m_cluster->data[size_t(t)]);
    if (k < 0 || k >= m_clusters)
      throw Error("compressed BTF (lpca): texel " + std::to_string(t) + " names cluster " +
                  std::to_string(k) + " of " + std::to_string(m_clusters));
    return k;
  }
  float dot(int ch, int64_t t, int64_t base, int64_t k) const {
    const int64_t C = m_b[ch]->cols;
    const float* b = m_b[ch]->row(base + k);
    const float* c = m_k[ch]->row(t) + (m_mode == 1 ? (k / m_n) * C : 0);
    double acc = 0;
    for (int64_t q = 0; q < C; ++q) acc += double(b[q]) * c[q];
    return float(acc);
  }
  CompressedBtf m_c;
  int m_n = 0, m_mode = 0, m_clusters = 1;
  int64_t m_lv = 0;
  const CArray* m_cluster = nullptr;
  const CArray *m_b[3], *m_k[3];
};

}  // namespace

std::unique_ptr<Encoder> makeSvdEncoder(const CodecSettings& s, const BtfInfo& i,
                                        const CancelToken* c) {
  return std::make_unique<SvdEncoder>(s, i, c);
}
std::unique_ptr<Encoder> makePerViewEncoder(const CodecSettings& s, const BtfInfo& i,
                                            const CancelToken* c) {
  return std::make_unique<PerViewEncoder>(s, i, c);
}
std::unique_ptr<Encoder> makeLpcaEncoder(const CodecSettings& s, const BtfInfo& i,
                                         const CancelToken* c) {
  return std::make_unique<LpcaEncoder>(s, i, c);
}
std::unique_ptr<Decoder> makeSvdDecoder(CompressedBtf c) {
  return std::make_unique<LinearDecoder>(std::move(c));
}
std::unique_ptr<Decoder> makePerViewDecoder(CompressedBtf c) {
  return std::make_unique<LinearDecoder>(std::move(c));
}
std::unique_ptr<Decoder> makeLpcaDecoder(CompressedBtf c) {
  return std::make_unique<LinearDecoder>(std::move(c));
}

}  // namespace btf
