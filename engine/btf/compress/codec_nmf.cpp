// The thesis's codec (§3.4): per texel and channel, the views × lights aBRDF matrix is factorised
// by NMF at the rank the β rule selects, initialised by NNDSVD; signed chroma channels (colour
// model ycc) take the truncated SVD instead. The unit-norm view and light factors of all texels
// are then projected on uncentred PCA bases (one per channel and side).
//
// Arrays, per channel c: c{c}.basis_view (nV × Cv), c{c}.basis_light (nL × Cl),
// c{c}.coef_view (texels × K·Cv) with the factor scale folded in, c{c}.coef_light (texels × K·Cl);
// K slots per texel (the largest rank; unused slots are zero).
//   value_c(t, v, l) = Σ_j (Σ_a basis_view[v, a] coef_view[t, j·Cv + a])
//                        · (Σ_b basis_light[l, b] coef_light[t, j·Cl + b])
#include <btf/core/error.h>
#include <btf/core/exact_sum.h>
#include <btf/core/sysinfo.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <nlohmann/json.hpp>

#include "codec.h"

namespace btf {
namespace {

struct TexelFactors {
  std::vector<float> scale;  // per factor
  std::vector<float> view;   // k × nV, unit rows
  std::vector<float> light;  // k × nL, unit rows
  int rank() const { return int(scale.size()); }
};

class NmfEncoder final : public Encoder {
 public:
  NmfEncoder(const CodecSettings& s, const BtfInfo& info, const CancelToken* cancel)
      : m_s(s), m_info(info), m_cancel(cancel) {
    m_n = info.nDirs();
    m_f.resize(size_t(info.texels()) * 3);
    m_done.assign(size_t(info.texels()), 0);
    m_texelErr2.assign(size_t(info.texels()) * 3, 0.0);
    m_texelEnergy.assign(size_t(info.texels()) * 3, 0.0);
  }

  std::string addedState() const override {
    StateWriter w;
    w.put<int64_t>(m_iters);
    w.put<int64_t>(m_solves);
    for (int64_t t = 0; t < int64_t(m_done.size()); ++t) {
      if (!m_done[size_t(t)]) continue;
      w.put<int64_t>(t);
      for (int c = 0; c < 3; ++c) {
        const size_t i = size_t(t) * 3 + size_t(c);
        w.put(m_texelErr2[i]);
        w.put(m_texelEnergy[i]);
        w.putVector(m_f[i].scale);
        w.putVector(m_f[i].view);
        w.putVector(m_f[i].light);
      }
    }
    return w.take();
  }
  void mergeAdded(const std::string& bytes) override {
    StateReader r(bytes);
    m_iters += r.get<int64_t>();
    m_solves += r.get<int64_t>();
    const uint64_t kMax = uint64_t(m_s.maxRank) * uint64_t(m_n);
    while (!r.done()) {
      const int64_t t = r.get<int64_t>();
      if (t < 0 || t >= int64_t(m_done.size())) throw Error("encoder state: texel out of range");
      for (int c = 0; c < 3; ++c) {
        const size_t i = size_t(t) * 3 + size_t(c);
        m_texelErr2[i] = r.get<double>();
        m_texelEnergy[i] = r.get<double>();
        m_f[i].scale = r.getVector<float>(uint64_t(m_s.maxRank));
        m_f[i].view = r.getVector<float>(kMax);
        m_f[i].light = r.getVector<float>(kMax);
        if (m_f[i].view.size() != m_f[i].scale.size() * size_t(m_n) ||
            m_f[i].light.size() != m_f[i].view.size())
          throw Error("encoder state: inconsistent factor sizes");
      }
      m_done[size_t(t)] = 1;
    }
  }

  void add(int64_t t0, int64_t t1, const float* values) override {
    const auto start = std::chrono::steady_clock::now();
    const size_t stride = size_t(m_n) * m_n * 3;
    parallelForChunks(
        t1 - t0, 1,
        [&](int64_t b, int64_t e) {
          la::MatF A(m_n, m_n);
          int64_t iters = 0, solves = 0;
          for (int64_t k = b; k < e; ++k) {
            const float* x = values + size_t(k) * stride;
            for (int c = 0; c < 3; ++c) {
              for (int v = 0; v < m_n; ++v)
                for (int l = 0; l < m_n; ++l) {
                  float col[3];
                  toColour(m_s.colour, x + (size_t(v) * m_n + l) * 3, col);
                  A(v, l) = col[c];
                }
              const size_t i = size_t(t0 + k) * 3 + size_t(c);
              factor(A, c, m_f[i], m_texelErr2[i], m_texelEnergy[i], iters, solves);
            }
            m_done[size_t(t0 + k)] = 1;
          }
          std::lock_guard<std::mutex> lock(m_mutex);
          m_iters += iters;
          m_solves += solves;
        },
        m_cancel);
    m_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  uint64_t memoryBytes() const override {
    // Estimated from the ranks so far (maxRank bound before any texel).
    return uint64_t(m_info.texels()) * 3 * uint64_t(m_s.maxRank) * uint64_t(2 * m_n + 1) * 4;
  }

  CompressedBtf finish() override { return finishOn(localComm()); }

  // Over the ranks of a job (docs/cluster.md): every statistic the file depends on is an exact
  // sum (btf/core/exact_sum.h) reduced across the ranks — slot counts, residuals, and the PCA
  // Gram matrices, accumulated per block of texels (32-texel cells cut at the store's chunk
  // boundaries, so each block is one rank's) — then each rank projects its own texels and rank 0
  // gathers only the coefficient rows. One process takes the same path: the same bits.
  CompressedBtf finishOn(Comm& comm) override {
    const int64_t T = m_info.texels();
    int64_t local = 0;
    for (uint8_t d : m_done) local += d;
    // This rank's blocks: 32-texel cells cut at the chunk boundaries, wholly added here.
    const int64_t cell = 32, chunk = std::max(1, m_info.chunkTexels);
    std::vector<std::pair<int64_t, int64_t>> blocks;
    int64_t split = 0;  // blocks only partly added here (the ranks did not hold whole chunks)
    for (int64_t t0 = 0; t0 < T;) {
      const int64_t t1 = std::min({T, (t0 / cell + 1) * cell, (t0 / chunk + 1) * chunk});
      int64_t here = 0;
      for (int64_t t = t0; t < t1; ++t) here += m_done[size_t(t)];
      if (here == t1 - t0) blocks.push_back({t0, t1});
      if (here != 0 && here != t1 - t0) ++split;
      t0 = t1;
    }
    // Every sum the file depends on, in one vector reduced once: factors per channel, the rank
    // histogram of channel 0, texels added, residual and energy per channel, NMF iterations and
    // solves, blocks split between ranks. K (slots) is a maximum, exchanged apart.
    const int H = m_s.maxRank + 1;
    const size_t kHist = 3, kAdded = kHist + size_t(H), kErr = kAdded + 1, kEnergy = kErr + 3,
                 kIters = kEnergy + 3, kSolves = kIters + 1, kSplit = kSolves + 1;
    std::vector<Exact> counts(kSplit + 1, 0);
    int K[3] = {0, 0, 0};
    for (int64_t t = 0; t < T; ++t) {
      if (!m_done[size_t(t)]) continue;
      for (int c = 0; c < 3; ++c) {
        const int r = m_f[size_t(t) * 3 + size_t(c)].rank();
        K[c] = std::max(K[c], r);
        counts[size_t(c)] += r;
        if (c == 0) counts[kHist + size_t(r)] += 1;
        const size_t i = size_t(t) * 3 + size_t(c);
        counts[kErr + size_t(c)] += toExact(m_texelErr2[i]);
        counts[kEnergy + size_t(c)] += toExact(m_texelEnergy[i]);
      }
    }
    counts[kAdded] = local;
    counts[kIters] = m_iters;
    counts[kSolves] = m_solves;
    counts[kSplit] = split;
    comm.sumExact(counts);
    // Every rank sees the same sums, so every rank fails together (CollectiveError).
    if (counts[kAdded] != T) {
      for (int64_t t = 0; t < T; ++t)
        if (!m_done[size_t(t)] && !comm.distributed())
          throw Error("nmf encoder: texel " + std::to_string(t) + " was never added");
      throw CollectiveError("nmf encoder: " + std::to_string(int64_t(counts[kAdded])) + " of " +
                            std::to_string(T) + " texels were added over the ranks");
    }
    if (counts[kSplit] > 0)
      throw CollectiveError("nmf encoder: " + std::to_string(int64_t(counts[kSplit])) +
                            " block(s) of texels were split between ranks (a rank must add whole "
                            "chunks of the store)");
    if (comm.distributed()) {
      std::string mine(reinterpret_cast<const char*>(K), sizeof K);
      for (const std::string& o : comm.allgather(mine)) {
        int k[3];
        std::memcpy(k, o.data(), sizeof k);
        for (int c = 0; c < 3; ++c) K[c] = std::max(K[c], k[c]);
      }
    }
    int64_t nf[3];
    double err2 = 0, energy = 0, chanEnergy[3];
    for (int c = 0; c < 3; ++c) {
      nf[c] = int64_t(counts[size_t(c)]);
      const double e2 = fromExact(counts[kErr + size_t(c)]);
      chanEnergy[c] = fromExact(counts[kEnergy + size_t(c)]);
      err2 += e2;
      energy += chanEnergy[c];
    }
    const int64_t iters = int64_t(counts[kIters]);
    const int64_t solves = int64_t(counts[kSolves]);

    CompressedBtf out;
    out.info = m_info;
    out.codec = "nmf";
    out.colour = m_s.colour;
    const ArrayType type = m_s.half ? ArrayType::F16 : ArrayType::F32;
    const double raw = double(T) * m_n * m_n * 12.0;
    nlohmann::ordered_json params = nlohmann::ordered_json::parse(settingsJson(m_s));
    nlohmann::ordered_json chans = nlohmann::ordered_json::array();
    // Components: explicit, from the ratio's size model, or from the error target.
    const int maxC = std::min(m_n, 256);
    const double nmfRel2 = energy > 0 ? err2 / energy : 0;
    const double target = m_s.targetRmse > 0 ? m_s.targetRmse : 0.05;
    // Error left to the PCA stage, split between the view and light sides.
    const double pcaBudget2 = std::max(target * target - nmfRel2, 0.25 * target * target) / 2;
    // PCA bases of every channel and side first (samples: s_j · unit factor — the
    // reconstruction error a side's projection error causes scales with s_j), then the counts.
    // Lower triangles of the six Gram matrices (channel, side), packed: entry (a, b ≤ a) of
    // matrix g at g · tri + a(a + 1)/2 + b.
    const size_t tri = size_t(m_n) * size_t(m_n + 1) / 2;
    std::vector<Exact> gram(6 * tri, 0);
    {
      std::mutex mutex;
      parallelForChunks(int64_t(blocks.size()) * 6, 1, [&](int64_t b0, int64_t b1) {
        std::vector<Exact> acc(tri, 0);
        int last = -1;
        auto flush = [&] {
          if (last < 0) return;
          std::lock_guard<std::mutex> lock(mutex);
          Exact* g = gram.data() + size_t(last) * tri;
          for (size_t i = 0; i < tri; ++i) g[i] += acc[i];
          std::fill(acc.begin(), acc.end(), Exact(0));
        };
        for (int64_t bi = b0; bi < b1; ++bi) {
          const auto [t0, t1] = blocks[size_t(bi / 6)];
          const int c = int(bi % 6) / 2, side = int(bi % 6) % 2;
          if (c * 2 + side != last) flush(), last = c * 2 + side;
          int64_t cols = 0;
          for (int64_t t = t0; t < t1; ++t) cols += m_f[size_t(t) * 3 + size_t(c)].rank();
          if (cols == 0) continue;
          Eigen::MatrixXd X(m_n, cols);
          int64_t col = 0;
          for (int64_t t = t0; t < t1; ++t) {
            const TexelFactors& f = m_f[size_t(t) * 3 + size_t(c)];
            for (int j = 0; j < f.rank(); ++j, ++col) {
              const float* src = (side == 0 ? f.view.data() : f.light.data()) + size_t(j) * m_n;
              for (int i = 0; i < m_n; ++i) X(i, col) = double(f.scale[size_t(j)] * src[i]);
            }
          }
          const Eigen::MatrixXd G = X * X.transpose();
          for (int a = 0; a < m_n; ++a)
            for (int b = 0; b <= a; ++b)
              acc[size_t(a) * (a + 1) / 2 + size_t(b)] += toExact(G(a, b));
        }
        flush();
      });
    }
    comm.sumExact(gram);
    la::Basis bases[3][2];
    for (int c = 0; c < 3; ++c) {
      if (K[c] == 0) continue;
      for (int side = 0; side < 2; ++side) {
        Eigen::MatrixXd G(m_n, m_n);
        const Exact* g = gram.data() + size_t(c * 2 + side) * tri;
        for (int a = 0; a < m_n; ++a)
          for (int b = 0; b <= a; ++b)
            G(a, b) = G(b, a) = fromExact(g[size_t(a) * (a + 1) / 2 + size_t(b)]);
        bases[c][side] = la::pcaBasisFromGram(G, maxC);
      }
    }
    int Cs[3][2] = {{0, 0}, {0, 0}, {0, 0}};
    auto avail = [&](int c, int side) { return int(bases[c][side].B.cols()); };
    if (m_s.components > 0) {
      for (int c = 0; c < 3; ++c)
        for (int side = 0; side < 2; ++side) Cs[c][side] = std::min(m_s.components, avail(c, side));
    } else if (m_s.targetRatio > 0) {
      // Greedy by energy per byte: a component of (channel, side) costs its basis column and one
      // coefficient per slot and texel; it removes its eigenvalue from the error. Each coded
      // channel starts with one component per side.
      const double scalar = m_s.half ? 2 : 4;
      // Header and alignment, and the visibility map beside the arrays.
      double budget = raw / m_s.targetRatio - 65536.0 - double(m_reservedBytes);
      auto cost = [&](int c) { return (double(m_n) + double(T) * K[c]) * scalar; };
      for (int c = 0; c < 3; ++c)
        for (int side = 0; side < 2; ++side)
          if (avail(c, side) > 0) Cs[c][side] = 1, budget -= cost(c);
      for (;;) {
        int bc = -1, bs = 0;
        double best = 0;
        for (int c = 0; c < 3; ++c)
          for (int side = 0; side < 2; ++side) {
            const int i = Cs[c][side];
            if (i >= avail(c, side) || cost(c) > budget) continue;
            const double gain = bases[c][side].eigen[i] / cost(c);
            if (gain > best) best = gain, bc = c, bs = side;
          }
        if (bc < 0) break;
        ++Cs[bc][bs];
        budget -= cost(bc);
      }
    } else {
      for (int c = 0; c < 3; ++c)
        for (int side = 0; side < 2; ++side) {
          if (avail(c, side) == 0) continue;
          // Residual as a fraction of the data energy (Σ s_j² ≈ ‖A‖²).
          const double frac = energy > 0 ? pcaBudget2 * chanEnergy[c] / bases[c][side].total : 0;
          Cs[c][side] = std::min(avail(c, side),
                                 std::max(1, la::componentsForResidual(bases[c][side], frac)));
        }
    }
    CArray* coef[3][2] = {{nullptr, nullptr}, {nullptr, nullptr}, {nullptr, nullptr}};
    for (int c = 0; c < 3; ++c) {
      nlohmann::ordered_json cj;
      cj["channel"] = c;
      cj["slots"] = K[c];
      cj["factors"] = nf[c];
      const la::Basis* bs = bases[c];
      const int Cv = Cs[c][0], Cl = Cs[c][1];
      cj["components_view"] = Cv;
      cj["components_light"] = Cl;
      chans.push_back(cj);
      CArray& bv = out.add(channelArray(c, "basis_view"), type, m_n, Cv);
      CArray& bl = out.add(channelArray(c, "basis_light"), type, m_n, Cl);
      for (int i = 0; i < m_n; ++i) {
        for (int a = 0; a < Cv; ++a) bv.data[size_t(i) * Cv + a] = bs[0].B(i, a);
        for (int a = 0; a < Cl; ++a) bl.data[size_t(i) * Cl + a] = bs[1].B(i, a);
      }
      CArray& cv = out.add(channelArray(c, "coef_view"), type, T, int64_t(K[c]) * Cv);
      CArray& cl = out.add(channelArray(c, "coef_light"), type, T, int64_t(K[c]) * Cl);
      coef[c][0] = &cv;
      coef[c][1] = &cl;
      // Quantize the bases first so the coefficients are fitted to what is stored.
      const la::MatF Bv = quantizedBasis(bv, Cv), Bl = quantizedBasis(bl, Cl);
      parallelForChunks(T, 256, [&](int64_t b, int64_t e) {
        for (int64_t t = b; t < e; ++t) {
          if (!m_done[size_t(t)]) continue;
          const TexelFactors& f = m_f[size_t(t) * 3 + size_t(c)];
          for (int j = 0; j < f.rank(); ++j) {
            Eigen::Map<const la::VecF> w(f.view.data() + size_t(j) * m_n, m_n);
            Eigen::Map<const la::VecF> h(f.light.data() + size_t(j) * m_n, m_n);
            const la::VecF a = Bv.transpose() * (f.scale[size_t(j)] * w);
            const la::VecF bb = Bl.transpose() * h;
            for (int q = 0; q < Cv; ++q) cv.data[size_t(t * cv.cols + j * Cv + q)] = a[q];
            for (int q = 0; q < Cl; ++q) cl.data[size_t(t * cl.cols + j * Cl + q)] = bb[q];
          }
        }
      });
    }
    if (comm.distributed()) {
      // Rank 0 gathers the coefficient rows of every other rank's texels (f16 when stored so).
      out.quantize();
      StateWriter w;
      for (int64_t t = 0; t < T; ++t) {
        if (!m_done[size_t(t)]) continue;
        w.put<int64_t>(t);
        for (auto& cc : coef)
          for (CArray* a : cc)
            for (int64_t k = 0; k < a->cols; ++k) {
              const float v = a->data[size_t(t * a->cols + k)];
              if (m_s.half)
                w.put<uint16_t>(la::floatToHalf(v));
              else
                w.put<float>(v);
            }
      }
      const std::vector<std::string> rows = comm.gather(w.take(), 0);
      if (!comm.root()) return CompressedBtf{};
      for (int q = 1; q < comm.size(); ++q) {
        StateReader r(rows[size_t(q)]);
        while (!r.done()) {
          const int64_t t = r.get<int64_t>();
          if (t < 0 || t >= T) throw Error("nmf encoder: a rank sent a texel out of range");
          for (auto& cc : coef)
            for (CArray* a : cc)
              for (int64_t k = 0; k < a->cols; ++k)
                a->data[size_t(t * a->cols + k)] =
                    m_s.half ? la::halfToFloat(r.get<uint16_t>()) : r.get<float>();
        }
      }
    }
    out.quantize();
    params["channels"] = chans;
    nlohmann::ordered_json hist = nlohmann::ordered_json::array();
    for (int r = 0; r < H; ++r) hist.push_back(int64_t(counts[kHist + size_t(r)]));
    params["rank_histogram_channel0"] = hist;
    out.paramsJson = params.dump();
    nlohmann::ordered_json st;
    // No timings in the file: the same request writes the same bytes (timings are in reports).
    st["nmf_relative_rmse"] = std::sqrt(nmfRel2);
    st["mean_nmf_iterations"] = solves ? double(iters) / double(solves) : 0.0;
    out.statsJson = st.dump();
    return out;
  }

 private:
  static la::MatF quantizedBasis(const CArray& a, int C) {
    la::MatF B(a.rows, C);
    for (int64_t i = 0; i < a.rows; ++i)
      for (int q = 0; q < C; ++q)
        B(i, q) =
            a.type == ArrayType::F16 ? la::halfToFloat(la::floatToHalf(a.at(i, q))) : a.at(i, q);
    return B;
  }

  void factor(const la::MatF& A, int c, TexelFactors& out, double& err2, double& energy,
              int64_t& iters, int64_t& solves) {
    const double norm2 = A.cast<double>().squaredNorm();
    energy = norm2;
    err2 = 0;
    out = TexelFactors{};
    if (!(norm2 > 0)) return;  // all-zero texel (fully shadowed): rank 0
    const la::Svd svd = la::truncatedSvd(A, m_s.maxRank, 2, m_s.seed);
    int k;
    if (m_s.betaMode == la::BetaMode::Singular)
      k = la::rankForBeta(la::singularValues(A), m_s.beta, la::BetaMode::Singular, norm2,
                          m_s.maxRank);
    else
      k = la::rankForBeta(svd.s, m_s.beta, la::BetaMode::Energy, norm2, m_s.maxRank);
    if (k == 0) return;
    la::MatF W, H;
    if (channelNonNegative(m_s.colour, c)) {
      la::NmfResult r = la::nmf(A, k, svd, m_s.solver, m_s.nmfIterations, m_s.nmfTolerance);
      W = std::move(r.W);
      H = std::move(r.H);
      iters += r.iterations;
      ++solves;
      err2 += r.objective.empty() ? norm2 : r.objective.back();
    } else {
      W = svd.U.leftCols(k);
      H = svd.s.head(k).cast<float>().asDiagonal() * svd.V.leftCols(k).transpose();
      double kept = 0;
      for (int i = 0; i < k; ++i) kept += svd.s[i] * svd.s[i];
      err2 += std::max(0.0, norm2 - kept);
    }
    for (int j = 0; j < W.cols(); ++j) {
      const double a = W.col(j).norm(), b = H.row(j).norm();
      if (!(a > 0 && b > 0) || !std::isfinite(a * b)) continue;
      out.scale.push_back(float(a * b));
      for (int i = 0; i < m_n; ++i) out.view.push_back(float(W(i, j) / a));
      for (int i = 0; i < m_n; ++i) out.light.push_back(float(H(j, i) / b));
    }
  }

  CodecSettings m_s;
  BtfInfo m_info;
  const CancelToken* m_cancel;
  int m_n = 0;
  std::vector<TexelFactors> m_f;
  std::vector<uint8_t> m_done;
  std::mutex m_mutex;
  double m_seconds = 0;
  std::vector<double> m_texelErr2, m_texelEnergy;  // per (texel, channel)
  int64_t m_iters = 0, m_solves = 0;
};

class NmfDecoder final : public Decoder {
 public:
  explicit NmfDecoder(CompressedBtf c) : Decoder(c.info), m_c(std::move(c)) {
    m_n = m_info.nDirs();
    for (int ch = 0; ch < 3; ++ch) {
      m_bv[ch] = &m_c.array(channelArray(ch, "basis_view"));
      m_bl[ch] = &m_c.array(channelArray(ch, "basis_light"));
      m_cv[ch] = &m_c.array(channelArray(ch, "coef_view"));
      m_cl[ch] = &m_c.array(channelArray(ch, "coef_light"));
      const int64_t Cv = m_bv[ch]->cols, Cl = m_bl[ch]->cols;
      if (m_bv[ch]->rows != m_n || m_bl[ch]->rows != m_n || m_cv[ch]->rows != m_info.texels() ||
          m_cl[ch]->rows != m_info.texels() || (Cv > 0 && m_cv[ch]->cols % Cv) ||
          (Cl > 0 && m_cl[ch]->cols % Cl) ||
          (Cv > 0 && Cl > 0 && m_cv[ch]->cols / Cv != m_cl[ch]->cols / Cl))
        throw Error("compressed BTF (nmf): channel " + std::to_string(ch) +
                    " arrays have inconsistent dimensions");
      m_K[ch] = Cv > 0 ? int(m_cv[ch]->cols / Cv) : 0;
      m_Bv[ch] = toMat(*m_bv[ch]);
      m_Bl[ch] = toMat(*m_bl[ch]);
    }
  }
  std::string kind() const override { return "nmf"; }

  void texel(int64_t t, float* out) const override {
    la::MatF M[3];
    for (int ch = 0; ch < 3; ++ch) {
      const int K = m_K[ch];
      if (K == 0) {
        M[ch] = la::MatF::Zero(m_n, m_n);
        continue;
      }
      const int Cv = int(m_bv[ch]->cols), Cl = int(m_bl[ch]->cols);
      Eigen::Map<const la::MatF> a(m_cv[ch]->row(t), Cv, K);  // column j = factor j
      Eigen::Map<const la::MatF> b(m_cl[ch]->row(t), Cl, K);
      M[ch] = (m_Bv[ch] * a) * (m_Bl[ch] * b).transpose();
    }
    for (int v = 0; v < m_n; ++v)
      for (int l = 0; l < m_n; ++l) {
        const float in[3] = {M[0](v, l), M[1](v, l), M[2](v, l)};
        fromColour(m_c.colour, in, out + (size_t(v) * m_n + l) * 3);
      }
  }

  std::array<float, 3> value(int64_t t, int view, int light) const override {
    float in[3] = {0, 0, 0};
    for (int ch = 0; ch < 3; ++ch) {
      const int Cv = int(m_bv[ch]->cols), Cl = int(m_bl[ch]->cols);
      const float* a = m_cv[ch]->row(t);
      const float* b = m_cl[ch]->row(t);
      const float* bv = m_bv[ch]->row(view);
      const float* bl = m_bl[ch]->row(light);
      double acc = 0;
      for (int j = 0; j < m_K[ch]; ++j) {
        double x = 0, y = 0;
        for (int q = 0; q < Cv; ++q) x += double(bv[q]) * a[j * Cv + q];
        for (int q = 0; q < Cl; ++q) y += double(bl[q]) * b[j * Cl + q];
        acc += x * y;
      }
      in[ch] = float(acc);
    }
    std::array<float, 3> rgb{};
    fromColour(m_c.colour, in, rgb.data());
    return rgb;
  }

 private:
  static la::MatF toMat(const CArray& a) {
    la::MatF M(a.rows, a.cols);
    for (int64_t i = 0; i < a.rows; ++i)
      for (int64_t j = 0; j < a.cols; ++j) M(i, j) = a.at(i, j);
    return M;
  }
  CompressedBtf m_c;
  int m_n = 0;
  int m_K[3] = {0, 0, 0};
  const CArray *m_bv[3], *m_bl[3], *m_cv[3], *m_cl[3];
  la::MatF m_Bv[3], m_Bl[3];
};

}  // namespace

std::unique_ptr<Encoder> makeNmfEncoder(const CodecSettings& s, const BtfInfo& info,
                                        const CancelToken* cancel) {
  return std::make_unique<NmfEncoder>(s, info, cancel);
}
std::unique_ptr<Decoder> makeNmfDecoder(CompressedBtf c) {
  return std::make_unique<NmfDecoder>(std::move(c));
}

}  // namespace btf
