// The tensor codec's encoder (layout and method: codec_tensor_internal.h): IRP k-means clustering
// on sign sketches, HOSVD + HOOI view and light bases per cluster, the streamed projections, the
// texel-mode cores and the greedy rank choice, written as the file's arrays.
#include "codec_tensor_internal.h"

namespace btf {

using namespace tensordetail;

namespace {

class TensorEncoder final : public Encoder {
 public:
  TensorEncoder(const CodecSettings& s, const BtfInfo& info, const CancelToken* cancel)
      : m_s(s),
        m_info(info),
        m_cancel(cancel),
        m_n(info.nDirs()),
        m_T(info.texels()),
        m_sketch(int64_t(info.nDirs()) * info.nDirs() * 3, kSketchDim, s.seed ^ 0x7e45a) {
    m_K = int(std::min<int64_t>(m_T, s.clusters > 0 ? s.clusters : autoClusters(m_T)));
    // Training texels: --train-texels, or more to give every cluster 32 for its bases up to
    // kTrainingBytes of values — a fixed bound, not the memory budget, so that compressing a
    // file and streaming from the simulator (whose budgets differ) choose the same texels.
    const uint64_t perTexel = uint64_t(m_n) * m_n * 3 * 4;
    const int64_t want = std::max<int64_t>(
        s.trainTexels, std::min<int64_t>(int64_t(32) * m_K,
                                         std::max<int64_t>(1, int64_t(kTrainingBytes / perTexel))));
    const int64_t m = std::min<int64_t>(m_T, want);
    // The default keeps at least 16 training texels per cluster (the bases are fitted on
    // them); an explicit --clusters at most one per training texel.
    m_K = int(std::max<int64_t>(1, std::min<int64_t>(m_K, s.clusters > 0 ? m : m / 16)));
    m_train = stratifiedTexels(info.nu, info.nv, int(m), s.seed);
    if (s.halfway) m_half = std::make_unique<HalfwayMap>(DirectionSet::fromName(info.directionSet));
    m_done.assign(size_t(m_T), 0);
    m_cluster.assign(size_t(m_T), 0);
    m_S.resize(size_t(m_T));
    m_energy.assign(size_t(m_T) * 3, 0.0);
    m_projected.assign(size_t(m_T) * 3, 0.0);
  }

  static int64_t autoClusters(int64_t T) {
    return std::max<int64_t>(1, std::llround(std::sqrt(double(T) / 2)));
  }

  std::vector<int64_t> trainingTexels() const override { return m_train; }

  // The training texels' matrices (train() keeps its own copy) and every texel's projections
  // (at most projectionFloats() each: the ranks are chosen within it).
  uint64_t memoryBytes() const override {
    const uint64_t train = uint64_t(m_train.size()) * m_n * m_n * 3 * 4;
    const uint64_t proj = uint64_t(m_T) * (uint64_t(projectionFloats()) * 4 + 64);
    return train + proj;
  }
  /// Floats a texel's projections (Σ over channels of Rv·Rl of its cluster) may take: the caps,
  /// or kProjectionBytes spread over the texels (fixed, like the training bound).
  int64_t projectionFloats() const {
    const int64_t caps = 3 * std::min<int64_t>(int64_t(m_n) * m_n, int64_t(kMaxRv) * kMaxRl);
    return std::min(caps, std::max<int64_t>(3 * 64, int64_t(kProjectionBytes / 4) / m_T));
  }

  void train(const float* values) override {
    const int64_t m = int64_t(m_train.size());
    const size_t stride = size_t(m_n) * m_n * 3;
    std::vector<la::MatF> X(size_t(m) * 3);
    la::MatF sk(kSketchDim, m);
    parallelForChunks(
        m, 1,
        [&](int64_t b, int64_t e) {
          std::vector<float> conv(stride), hw(m_half ? stride : 0);
          for (int64_t i = b; i < e; ++i) {
            toMatrices(halfway(values + size_t(i) * stride, hw), conv.data(), &X[size_t(i) * 3]);
            m_sketch.apply(conv.data(), sk.col(i).data());
          }
        },
        m_cancel);
    const la::KMeansResult km = la::irpKMeans(sk, m_K, m_s.seed);
    m_irpDims = km.dims;
    m_reseeds = km.reseeds;
    // Clusters the last Lloyd iteration left empty are dropped: a streamed texel nearest to
    // such a centre would find no bases there.
    std::vector<std::vector<int64_t>> members;
    std::vector<int64_t> keep;
    {
      std::vector<std::vector<int64_t>> all(static_cast<size_t>(km.centres.cols()));
      for (int64_t i = 0; i < m; ++i) all[size_t(km.assign[size_t(i)])].push_back(i);
      for (size_t k = 0; k < all.size(); ++k)
        if (!all[k].empty()) keep.push_back(int64_t(k)), members.push_back(std::move(all[k]));
    }
    m_centres.resize(km.centres.rows(), int64_t(keep.size()));
    for (size_t k = 0; k < keep.size(); ++k) m_centres.col(int64_t(k)) = km.centres.col(keep[k]);
    m_K = int(keep.size());

    // Spectra per (cluster, channel), scaled to the cluster's estimated share of all texels.
    const size_t KC = size_t(m_K) * 3;
    std::vector<la::ModeSpectra> spec(KC);
    std::vector<double> scale(KC, 0), estTexels(size_t(m_K), 0);
    for (int k = 0; k < m_K; ++k)
      estTexels[size_t(k)] = double(m_T) * double(members[size_t(k)].size()) / double(m);
    parallelForChunks(
        int64_t(KC), 1,
        [&](int64_t b, int64_t e) {
          for (int64_t kc = b; kc < e; ++kc) {
            const int k = int(kc / 3), c = int(kc % 3);
            spec[size_t(kc)] = la::modeSpectra(slices(X, members[size_t(k)], c), kMaxRv);
            scale[size_t(kc)] = members[size_t(k)].empty()
                                    ? 0.0
                                    : estTexels[size_t(k)] / double(members[size_t(k)].size());
          }
        },
        m_cancel);
    m_ranks.assign(KC, Ranks{});
    chooseTrainingRanks(spec, scale, estTexels);
    // HOOI on the training texels at the chosen ranks: the view and light bases.
    m_Uv.assign(KC, la::MatF());
    m_Ul.assign(KC, la::MatF());
    std::vector<double> err(KC, 0), energy(KC, 0);
    parallelForChunks(
        int64_t(KC), 1,
        [&](int64_t b, int64_t e) {
          for (int64_t kc = b; kc < e; ++kc) {
            const int k = int(kc / 3), c = int(kc % 3);
            Ranks& r = m_ranks[size_t(kc)];
            const auto sl = slices(X, members[size_t(k)], c);
            for (const la::MatF* a : sl) energy[size_t(kc)] += a->cast<double>().squaredNorm();
            if (r.v == 0) continue;
            const la::Tucker3 t =
                la::hooi(sl, r.v, r.l, r.t, kHooiSweeps, nullptr, &spec[size_t(kc)]);
            err[size_t(kc)] = t.error;
            m_Uv[size_t(kc)] = quantized(t.Uv);
            m_Ul[size_t(kc)] = quantized(t.Ul);
            r.v = int(t.Uv.cols());
            r.l = int(t.Ul.cols());
          }
        },
        m_cancel);
    double e = 0, tot = 0;
    for (size_t kc = 0; kc < KC; ++kc) e += err[kc], tot += energy[kc];
    m_trainRel = tot > 0 ? std::sqrt(e / tot) : 0;
    m_trained = true;
  }

  std::string addedState() const override {
    StateWriter w;
    for (int64_t t = 0; t < m_T; ++t) {
      if (!m_done[size_t(t)]) continue;
      w.put<int64_t>(t);
      w.put<int32_t>(m_cluster[size_t(t)]);
      for (int c = 0; c < 3; ++c) {
        w.put(m_energy[size_t(t) * 3 + size_t(c)]);
        w.put(m_projected[size_t(t) * 3 + size_t(c)]);
      }
      w.putVector(m_S[size_t(t)]);
    }
    return w.take();
  }
  void mergeAdded(const std::string& bytes) override {
    if (!m_trained) throw Error("tensor encoder: mergeAdded() before train()");
    StateReader r(bytes);
    while (!r.done()) {
      const int64_t t = r.get<int64_t>();
      if (t < 0 || t >= m_T) throw Error("encoder state: texel out of range");
      const int k = r.get<int32_t>();
      if (k < 0 || k >= m_K) throw Error("encoder state: cluster out of range");
      m_cluster[size_t(t)] = k;
      for (int c = 0; c < 3; ++c) {
        m_energy[size_t(t) * 3 + size_t(c)] = r.get<double>();
        m_projected[size_t(t) * 3 + size_t(c)] = r.get<double>();
      }
      uint64_t expect = 0;
      for (int c = 0; c < 3; ++c)
        expect += uint64_t(m_ranks[size_t(k) * 3 + size_t(c)].v) *
                  uint64_t(m_ranks[size_t(k) * 3 + size_t(c)].l);
      m_S[size_t(t)] = r.getVector<float>(expect);
      if (m_S[size_t(t)].size() != expect) throw Error("encoder state: projection size mismatch");
      m_done[size_t(t)] = 1;
    }
  }

  void add(int64_t t0, int64_t t1, const float* values) override {
    if (!m_trained) throw Error("tensor encoder: add() before train()");
    const size_t stride = size_t(m_n) * m_n * 3;
    parallelForChunks(
        t1 - t0, 1,
        [&](int64_t b, int64_t e) {
          std::vector<float> conv(stride), sk(kSketchDim), hw(m_half ? stride : 0);
          la::MatF A[3];
          for (int64_t i = b; i < e; ++i) {
            const int64_t t = t0 + i;
            toMatrices(halfway(values + size_t(i) * stride, hw), conv.data(), A);
            m_sketch.apply(conv.data(), sk.data());
            const int k = la::nearestCentre(m_centres, sk.data());
            m_cluster[size_t(t)] = k;
            std::vector<float>& S = m_S[size_t(t)];
            S.clear();
            for (int c = 0; c < 3; ++c) {
              const size_t kc = size_t(k) * 3 + size_t(c);
              m_energy[size_t(t) * 3 + size_t(c)] = A[c].cast<double>().squaredNorm();
              const Ranks& r = m_ranks[kc];
              if (r.v == 0) continue;
              const la::MatF P = m_Uv[kc].transpose() * A[c] * m_Ul[kc];  // Rv × Rl
              double p2 = 0;
              for (int a = 0; a < r.v; ++a)
                for (int bb = 0; bb < r.l; ++bb) {
                  S.push_back(P(a, bb));
                  p2 += double(P(a, bb)) * P(a, bb);
                }
              m_projected[size_t(t) * 3 + size_t(c)] = p2;
            }
            m_done[size_t(t)] = 1;
          }
        },
        m_cancel);
  }

  CompressedBtf finish() override {
    for (int64_t t = 0; t < m_T; ++t)
      if (!m_done[size_t(t)])
        throw Error("tensor encoder: texel " + std::to_string(t) + " was never added");
    const size_t KC = size_t(m_K) * 3;
    std::vector<std::vector<int64_t>> members(static_cast<size_t>(m_K));
    for (int64_t t = 0; t < m_T; ++t) members[size_t(m_cluster[size_t(t)])].push_back(t);
    // Texel mode per (cluster, channel): eigen-decomposition of the projected texels' Gram
    // matrix, accumulated in texel order (the same bits for any chunking of the stream).
    std::vector<la::VecD> lam(KC);
    std::vector<Eigen::MatrixXd> vec(KC);
    parallelForChunks(
        int64_t(KC), 1,
        [&](int64_t b, int64_t e) {
          for (int64_t kc = b; kc < e; ++kc) {
            const int k = int(kc / 3), c = int(kc % 3);
            const Ranks& r = m_ranks[size_t(kc)];
            const int64_t d = int64_t(r.v) * r.l;
            if (d == 0) continue;
            const auto& mem = members[size_t(k)];
            Eigen::MatrixXd Z(d, int64_t(mem.size()));
            for (size_t i = 0; i < mem.size(); ++i) {
              const float* s = m_S[size_t(mem[i])].data() + offsetInS(k, c);
              for (int64_t q = 0; q < d; ++q) Z(q, int64_t(i)) = s[q];
            }
            // One GEMM of sizes fixed by the data (not by the stream's chunking), on the smaller
            // side: with fewer texels than d the texels' Gram matrix gives the same nonzero
            // eigenvalues and the eigenvectors Z v / √λ.
            la::VecD& L = lam[size_t(kc)];
            Eigen::MatrixXd& V = vec[size_t(kc)];
            if (Z.cols() < d) {
              Eigen::MatrixXd W;
              la::symmetricEigen(Z.transpose() * Z, L, W);
              V = Eigen::MatrixXd::Zero(d, L.size());
              for (int64_t j = 0; j < L.size(); ++j)
                if (L[j] > 1e-12 * L[0])
                  V.col(j) = Z * W.col(j) / std::sqrt(L[j]);
                else
                  L[j] = 0;
            } else {
              la::symmetricEigen(Z * Z.transpose(), L, V);
            }
            if (V.cols() > kMaxRt) V.conservativeResize(Eigen::NoChange, kMaxRt);
          }
        },
        m_cancel);
    chooseTexelRanks(lam, members);

    CompressedBtf out;
    out.info = m_info;
    out.codec = "tensor";
    out.colour = m_s.colour;
    const ArrayType type = m_s.half ? ArrayType::F16 : ArrayType::F32;
    CArray& cl = out.add("cluster", m_K <= 2048 ? ArrayType::F16 : ArrayType::F32, m_T, 1);
    for (int64_t t = 0; t < m_T; ++t) cl.data[size_t(t)] = float(m_cluster[size_t(t)]);
    std::vector<la::MatF> E(KC);  // stored cores, (Rv·Rl) × Rt, row a·Rl + b
    int64_t coefRows = 0;
    for (int64_t t = 0; t < m_T; ++t)
      for (int c = 0; c < 3; ++c) coefRows += m_ranks[size_t(m_cluster[size_t(t)]) * 3 + c].t;
    for (int c = 0; c < 3; ++c) {
      CArray& rk = out.add(channelArray(c, "ranks"), ArrayType::F32, m_K, 3);
      int64_t nv = 0, nl = 0, nc = 0;
      for (int k = 0; k < m_K; ++k) {
        const Ranks& r = m_ranks[size_t(k) * 3 + size_t(c)];
        rk.data[size_t(k) * 3 + 0] = float(r.v);
        rk.data[size_t(k) * 3 + 1] = float(r.l);
        rk.data[size_t(k) * 3 + 2] = float(r.t);
        nv += int64_t(m_n) * r.v;
        nl += int64_t(m_n) * r.l;
        nc += int64_t(r.t) * r.v * r.l;
      }
      CArray& av = out.add(channelArray(c, "view"), type, nv, 1);
      CArray& al = out.add(channelArray(c, "light"), type, nl, 1);
      CArray& ac = out.add(channelArray(c, "core"), type, nc, 1);
      int64_t ov = 0, ol = 0, oc = 0;
      for (int k = 0; k < m_K; ++k) {
        const size_t kc = size_t(k) * 3 + size_t(c);
        const Ranks& r = m_ranks[kc];
        for (int v = 0; v < m_n; ++v)
          for (int a = 0; a < r.v; ++a) av.data[size_t(ov++)] = m_Uv[kc](v, a);
        for (int l = 0; l < m_n; ++l)
          for (int b = 0; b < r.l; ++b) al.data[size_t(ol++)] = m_Ul[kc](l, b);
        // The core: the top Rt texel-mode eigenvectors, rows in S's order (a·Rl + b).
        const int64_t d = int64_t(r.v) * r.l;
        E[kc] = la::MatF(d, r.t);
        for (int j = 0; j < r.t; ++j)
          for (int64_t q = 0; q < d; ++q) {
            const float x = roundStored(float(vec[kc](q, j)), m_s.half);
            E[kc](q, j) = x;
            ac.data[size_t(oc++)] = x;
          }
      }
    }
    // Coefficients fitted to the stored core (least squares on its Gram matrix).
    std::vector<la::MatF> gramInv(KC);
    for (size_t kc = 0; kc < KC; ++kc)
      if (m_ranks[kc].t > 0)
        gramInv[kc] = (E[kc].transpose() * E[kc])
                          .ldlt()
                          .solve(la::MatF::Identity(m_ranks[kc].t, m_ranks[kc].t));
    CArray& co = out.add("coef", type, coefRows, 1);
    std::vector<int64_t> offset(size_t(m_T) + 1, 0);
    for (int64_t t = 0; t < m_T; ++t) {
      int64_t n = 0;
      for (int c = 0; c < 3; ++c) n += m_ranks[size_t(m_cluster[size_t(t)]) * 3 + size_t(c)].t;
      offset[size_t(t) + 1] = offset[size_t(t)] + n;
    }
    parallelForChunks(m_T, 64, [&](int64_t b, int64_t e) {
      for (int64_t t = b; t < e; ++t) {
        const int k = m_cluster[size_t(t)];
        int64_t o = offset[size_t(t)];
        for (int c = 0; c < 3; ++c) {
          const size_t kc = size_t(k) * 3 + size_t(c);
          const Ranks& r = m_ranks[kc];
          if (r.t == 0) continue;
          const Eigen::Map<const la::VecF> s(m_S[size_t(t)].data() + offsetInS(k, c),
                                             int64_t(r.v) * r.l);
          const la::VecF u = gramInv[kc] * (E[kc].transpose() * s);
          for (int j = 0; j < r.t; ++j) co.data[size_t(o++)] = u[j];
        }
      }
    });
    out.quantize();

    // Errors before quantisation: the view/light projection (exact per texel) and the dropped
    // texel-mode eigenvalues.
    double energy = 0, proj = 0, kept = 0;
    totals(energy, proj);
    for (size_t kc = 0; kc < KC; ++kc)
      for (int j = 0; j < m_ranks[kc].t; ++j) kept += at(lam[kc], j);
    nlohmann::ordered_json params = nlohmann::ordered_json::parse(settingsJson(m_s));
    params["clusters_used"] = m_K;
    params["training_texels"] = m_train.size();
    params["sketch_dim"] = kSketchDim;
    params["irp_dims"] = m_irpDims;
    params["hooi_sweeps"] = kHooiSweeps;
    params["empty_cluster_reseeds"] = m_reseeds;
    nlohmann::ordered_json rj = nlohmann::ordered_json::array();
    for (int c = 0; c < 3; ++c) {
      int64_t sv = 0, sl = 0, st = 0, used = 0;
      for (int k = 0; k < m_K; ++k) {
        const Ranks& r = m_ranks[size_t(k) * 3 + size_t(c)];
        if (r.v == 0) continue;
        sv += r.v, sl += r.l, st += r.t, ++used;
      }
      nlohmann::ordered_json cj;
      cj["channel"] = c;
      cj["clusters_coded"] = used;
      cj["mean_ranks"] = {used ? double(sv) / double(used) : 0.0,
                          used ? double(sl) / double(used) : 0.0,
                          used ? double(st) / double(used) : 0.0};
      rj.push_back(cj);
    }
    params["channels"] = rj;
    out.paramsJson = params.dump();
    nlohmann::ordered_json st;
    st["training_relative_rmse"] = m_trainRel;
    st["projection_relative_rmse"] =
        energy > 0 ? std::sqrt(std::max(0.0, energy - proj) / energy) : 0.0;
    st["relative_rmse_estimate"] =
        energy > 0 ? std::sqrt(std::max(0.0, energy - kept) / energy) : 0.0;
    if (!m_ratioLimit.empty()) st["ratio_limit"] = m_ratioLimit;
    out.statsJson = st.dump();
    return out;
  }

 private:
  // A texel's values in half-vector coordinates (into `buf`) when the option is on.
  const float* halfway(const float* x, std::vector<float>& buf) const {
    if (!m_half) return x;
    m_half->forward(x, buf.data());
    return buf.data();
  }

  la::MatF quantized(la::MatF M) const {
    for (int64_t i = 0; i < M.size(); ++i) M.data()[i] = roundStored(M.data()[i], m_s.half);
    return M;
  }

  // Texel values ([view][light][rgb]) → colour-converted copy (same layout) and the three
  // channel matrices (views × lights).
  void toMatrices(const float* x, float* conv, la::MatF* A) const {
    for (int c = 0; c < 3; ++c) A[c].resize(m_n, m_n);
    for (int v = 0; v < m_n; ++v)
      for (int l = 0; l < m_n; ++l) {
        const size_t o = (size_t(v) * m_n + l) * 3;
        float col[3];
        toColour(m_s.colour, x + o, col);
        for (int c = 0; c < 3; ++c) {
          const float y = std::isfinite(col[c]) ? col[c] : 0.f;
          conv[o + size_t(c)] = y;
          A[c](v, l) = y;
        }
      }
  }

  static std::vector<const la::MatF*> slices(const std::vector<la::MatF>& X,
                                             const std::vector<int64_t>& idx, int c) {
    std::vector<const la::MatF*> s;
    for (int64_t i : idx) s.push_back(&X[size_t(i) * 3 + size_t(c)]);
    return s;
  }

  // Σ over texels and channels of ‖A‖² and of ‖Uvᵀ A Ul‖², in texel order.
  void totals(double& energy, double& projected) const {
    for (size_t i = 0; i < m_energy.size(); ++i) energy += m_energy[i], projected += m_projected[i];
  }

  int64_t offsetInS(int k, int c) const {
    int64_t o = 0;
    for (int q = 0; q < c; ++q) {
      const Ranks& r = m_ranks[size_t(k) * 3 + size_t(q)];
      o += int64_t(r.v) * r.l;
    }
    return o;
  }

  double scalarBytes() const { return m_s.half ? 2 : 4; }
  double rawBytes() const { return double(m_T) * m_n * m_n * 12.0; }
  // The header (the source's header, directions, settings; 4 KiB more for what finish() adds to
  // params and stats), the 14 arrays' alignment, the cluster ids and the rank tables.
  double fixedBytes() const {
    if (m_headerBytes == 0) {
      CompressedBtf probe;
      probe.info = m_info;
      probe.codec = "tensor";
      probe.colour = m_s.colour;
      probe.paramsJson = settingsJson(m_s);
      m_headerBytes = double(probe.fileBytes()) + 4096 + 14 * 64;
    }
    return m_headerBytes + double(m_T) * (m_K <= 2048 ? 2 : 4) + 3.0 * m_K * 3 * 4;
  }
  mutable double m_headerBytes = 0;

  // Ranks (Rv, Rl, planned Rt) per (cluster, channel) from the training spectra: explicit
  // (--components caps every mode), or greedy by estimated energy per byte (HOSVD bound: the
  // dropped eigenvalues of the three modes) until the ratio's byte budget is spent or the
  // estimated error reaches the target.
  void chooseTrainingRanks(const std::vector<la::ModeSpectra>& spec,
                           const std::vector<double>& scale, const std::vector<double>& estTexels) {
    const size_t KC = spec.size();
    auto capV = [&](size_t kc) {
      return int(std::min<int64_t>(kMaxRv, std::min<int64_t>(m_n, spec[kc].view.size())));
    };
    auto capT = [&](size_t kc) { return int(std::min<int64_t>(kMaxRt, spec[kc].texel.size())); };
    if (m_s.components > 0) {
      for (size_t kc = 0; kc < KC; ++kc) {
        if (!(spec[kc].energy > 0)) continue;
        Ranks& r = m_ranks[kc];
        r.v = r.l = std::min(m_s.components, capV(kc));
        r.t = std::min({m_s.components, capT(kc), r.v * r.l});
      }
      return;
    }
    const double sb = scalarBytes();
    double total = 0;
    for (size_t kc = 0; kc < KC; ++kc) total += scale[kc] * spec[kc].energy;
    const bool byRatio = m_s.targetRatio > 0;
    const double target = m_s.targetRmse > 0 ? m_s.targetRmse : 0.05;
    double budget =
        byRatio ? rawBytes() / m_s.targetRatio - fixedBytes() - double(m_reservedBytes) : 0;
    double err = 0;
    auto cost = [&](size_t kc, int mode) {
      const Ranks& r = m_ranks[kc];
      const double Tk = estTexels[kc / 3];
      if (mode == 0) return sb * (m_n + double(r.l) * r.t);
      if (mode == 1) return sb * (m_n + double(r.v) * r.t);
      return sb * (Tk + double(r.v) * r.l);
    };
    for (size_t kc = 0; kc < KC; ++kc) {
      if (!(spec[kc].energy > 0) || capV(kc) == 0 || capT(kc) == 0) continue;
      m_ranks[kc] = Ranks{1, 1, 1};
      budget -= sb * (2.0 * m_n + 1 + estTexels[kc / 3]);
    }
    auto gain = [&](size_t kc, int mode) {
      const Ranks& r = m_ranks[kc];
      const la::ModeSpectra& s = spec[kc];
      if (mode == 0) return r.v < capV(kc) ? scale[kc] * at(s.view, r.v) : 0.0;
      if (mode == 1) return r.l < capV(kc) ? scale[kc] * at(s.light, r.l) : 0.0;
      return r.t < std::min(capT(kc), r.v * r.l) ? scale[kc] * at(s.texel, r.t) : 0.0;
    };
    for (size_t kc = 0; kc < KC; ++kc) {
      const Ranks& r = m_ranks[kc];
      if (r.v == 0) {
        err += scale[kc] * spec[kc].energy;
        continue;
      }
      err += scale[kc] *
             (tail(spec[kc].view, r.v) + tail(spec[kc].light, r.l) + tail(spec[kc].texel, r.t));
    }
    for (;;) {
      if (!byRatio && err <= target * target * total) break;
      size_t bk = KC;
      int bm = 0;
      double best = 0;
      for (size_t kc = 0; kc < KC; ++kc) {
        if (m_ranks[kc].v == 0) continue;
        for (int mode = 0; mode < 3; ++mode) {
          const double g = gain(kc, mode), c = cost(kc, mode);
          if (!(g > 0) || (byRatio && c > budget)) continue;
          if (mode < 2 && projectionAfter(kc, mode) > projectionFloats()) {
            m_projectionBound = true;
            continue;
          }
          if (g / c > best) best = g / c, bk = kc, bm = mode;
        }
      }
      if (bk == KC) break;
      err -= gain(bk, bm);
      budget -= cost(bk, bm);
      Ranks& r = m_ranks[bk];
      (bm == 0 ? r.v : bm == 1 ? r.l : r.t) += 1;
    }
  }

  // A cluster's projection floats per texel if (cluster, channel) kc grew by one in `mode`.
  int64_t projectionAfter(size_t kc, int mode) const {
    const size_t k0 = kc / 3 * 3;
    int64_t sum = 0;
    for (size_t q = k0; q < k0 + 3; ++q) {
      const Ranks& r = m_ranks[q];
      sum += int64_t(r.v + (q == kc && mode == 0)) * (r.l + (q == kc && mode == 1));
    }
    return sum;
  }

  // Texel-mode ranks from the spectra of every texel's projection: explicit, or greedy with
  // the bytes left after the bases (ratio), or until the error — the exact view/light
  // projection error plus the dropped texel-mode eigenvalues — reaches the target.
  void chooseTexelRanks(const std::vector<la::VecD>& lam,
                        const std::vector<std::vector<int64_t>>& members) {
    const size_t KC = lam.size();
    auto cap = [&](size_t kc) {
      const Ranks& r = m_ranks[kc];
      return int(std::min<int64_t>(
          {kMaxRt, int64_t(r.v) * r.l, int64_t(members[kc / 3].size()), lam[kc].size()}));
    };
    // A cluster no texel chose codes nothing (its S offsets are never read again).
    for (size_t kc = 0; kc < KC; ++kc)
      if (members[kc / 3].empty()) m_ranks[kc] = Ranks{};
    if (m_s.components > 0) {
      for (size_t kc = 0; kc < KC; ++kc) m_ranks[kc].t = std::min(m_s.components, cap(kc));
      return;
    }
    const double sb = scalarBytes();
    double energy = 0, proj = 0;
    totals(energy, proj);
    const bool byRatio = m_s.targetRatio > 0;
    const double target = m_s.targetRmse > 0 ? m_s.targetRmse : 0.05;
    double budget = rawBytes() / (byRatio ? m_s.targetRatio : 1) - fixedBytes() -
                    (byRatio ? double(m_reservedBytes) : 0.0);
    for (size_t kc = 0; kc < KC; ++kc) budget -= sb * m_n * double(m_ranks[kc].v + m_ranks[kc].l);
    auto cost = [&](size_t kc) {
      return sb * (double(members[kc / 3].size()) + double(m_ranks[kc].v) * m_ranks[kc].l);
    };
    double err = std::max(0.0, energy - proj);
    for (size_t kc = 0; kc < KC; ++kc) {
      m_ranks[kc].t = std::min(1, cap(kc));
      if (m_ranks[kc].t) budget -= cost(kc);
      err += tail(lam[kc], m_ranks[kc].t);
    }
    for (;;) {
      if (!byRatio && err <= target * target * energy) break;
      size_t bk = KC;
      double best = 0;
      for (size_t kc = 0; kc < KC; ++kc) {
        if (m_ranks[kc].t == 0 || m_ranks[kc].t >= cap(kc)) continue;
        const double g = at(lam[kc], m_ranks[kc].t), c = cost(kc);
        if (!(g > 0) || (byRatio && c > budget)) continue;
        if (g / c > best) best = g / c, bk = kc;
      }
      if (bk == KC) break;
      err -= at(lam[bk], m_ranks[bk].t);
      budget -= cost(bk);
      ++m_ranks[bk].t;
    }
    // (Data coded to its float rounding has nothing left to spend bytes on.)
    if (byRatio && budget > 0.1 * rawBytes() / m_s.targetRatio && err > 1e-9 * energy) {
      // The ratio asked could not be spent: say which limits held the ranks.
      int atT = 0, atV = 0, coded = 0;
      for (size_t kc = 0; kc < KC; ++kc) {
        if (m_ranks[kc].v == 0) continue;
        ++coded;
        atT += m_ranks[kc].t >= cap(kc);
        atV += m_ranks[kc].v >= std::min(kMaxRv, m_n) && m_ranks[kc].l >= std::min(kMaxRl, m_n);
      }
      m_ratioLimit = format(
          "%.0f %% of the bytes unspent: %d of %d (cluster, channel) texel ranks at their cap "
          "(≤ %d, ≤ Rv·Rl, ≤ its texels), %d at the view/light caps (%d)%s; %d clusters from %zu "
          "training texels — more clusters spend more (--clusters K with --train-texels ≥ 16·K)",
          100 * budget / (rawBytes() / m_s.targetRatio), atT, coded, kMaxRt, atV,
          std::min(kMaxRv, m_n),
          m_projectionBound ? format(", view/light growth held by the projections' memory bound "
                                     "(Σ Rv·Rl ≤ %lld floats per texel)",
                                     (long long)projectionFloats())
                                  .c_str()
                            : "",
          m_K, m_train.size());
    }
  }

  CodecSettings m_s;
  BtfInfo m_info;
  const CancelToken* m_cancel;
  int m_n;
  int64_t m_T;
  int m_K = 1;
  la::SignSketch m_sketch;
  std::vector<int64_t> m_train;
  std::vector<uint8_t> m_done;
  std::vector<int> m_cluster;
  std::vector<std::vector<float>> m_S;  // per texel: Uvᵀ A_c Ul of each coded channel
  std::vector<double> m_energy;         // per texel and channel: ‖A_c‖²
  std::vector<double> m_projected;      // per texel and channel: ‖Uvᵀ A_c Ul‖²
  la::MatF m_centres;
  std::vector<Ranks> m_ranks;        // per (cluster, channel)
  std::vector<la::MatF> m_Uv, m_Ul;  // per (cluster, channel), as stored
  std::vector<int> m_irpDims;
  int m_reseeds = 0;
  double m_trainRel = 0;
  bool m_trained = false;
  bool m_projectionBound = false;      // the projections' memory held a view/light rank
  std::string m_ratioLimit;            // why the ratio asked was not reached (empty: it was)
  std::unique_ptr<HalfwayMap> m_half;  // --halfway
};

}  // namespace

std::unique_ptr<Encoder> makeTensorEncoder(const CodecSettings& s, const BtfInfo& info,
                                           const CancelToken* cancel) {
  return std::make_unique<TensorEncoder>(s, info, cancel);
}

}  // namespace btf
