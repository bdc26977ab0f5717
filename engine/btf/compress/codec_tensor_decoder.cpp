// The tensor codec's decoder (layout: codec_tensor_internal.h): values at set directions, texel
// levels, and the tables the GLSL decoder reads.
#include "codec_tensor_internal.h"

namespace btf {

using namespace tensordetail;

namespace {

// ------------------------------------------------------------------ decoder

class TensorDecoder final : public Decoder {
 public:
  /// `projected`: also build the per-(cluster, view) projected cores for random access (the GPU
  /// tables do not need them).
  explicit TensorDecoder(CompressedBtf c, bool projected = true)
      : Decoder(c.info), m_c(std::move(c)) {
    m_n = m_info.nDirs();
    const int64_t T = m_info.texels();
    const CArray& cl = m_c.array("cluster");
    if (cl.rows != T || cl.cols != 1)
      throw Error("compressed BTF (tensor): the cluster array is " + std::to_string(cl.rows) +
                  " × " + std::to_string(cl.cols) + ", expected " + std::to_string(T) + " × 1");
    for (int ch = 0; ch < 3; ++ch) {
      const CArray& rk = m_c.array(channelArray(ch, "ranks"));
      if (rk.cols != 3 || rk.rows < 1 || (ch > 0 && rk.rows != m_K))
        throw Error("compressed BTF (tensor): channel " + std::to_string(ch) + " ranks array is " +
                    std::to_string(rk.rows) + " × " + std::to_string(rk.cols) +
                    " (expected one row of 3 per cluster)");
      m_K = int(rk.rows);
      int64_t nv = 0, nl = 0, nc = 0;
      for (int k = 0; k < m_K; ++k) {
        const float v = rk.at(k, 0), l = rk.at(k, 1), t = rk.at(k, 2);
        const int cv = std::min(kMaxRv, m_n), clim = std::min(kMaxRl, m_n);
        if (!(v >= 0 && v <= cv && v == std::floor(v) && l >= 0 && l <= clim &&
              l == std::floor(l) && t >= 0 && t <= std::min<float>(kMaxRt, v * l) &&
              t == std::floor(t)))
          throw Error("compressed BTF (tensor): channel " + std::to_string(ch) + " cluster " +
                      std::to_string(k) + " has invalid ranks (" + std::to_string(v) + ", " +
                      std::to_string(l) + ", " + std::to_string(t) + ")");
        Ranks r{int(v), int(l), int(t)};
        m_offV[ch].push_back(nv);
        m_offL[ch].push_back(nl);
        m_offC[ch].push_back(nc);
        m_r[ch].push_back(r);
        nv += int64_t(m_n) * r.v;
        nl += int64_t(m_n) * r.l;
        nc += int64_t(r.t) * r.v * r.l;
      }
      m_view[ch] = &checked(channelArray(ch, "view"), nv);
      m_light[ch] = &checked(channelArray(ch, "light"), nl);
      m_core[ch] = &checked(channelArray(ch, "core"), nc);
    }
    // Every texel's cluster (an integer within the clusters) and coefficient offset.
    m_texCluster.resize(size_t(T));
    m_texOffset.resize(size_t(T) + 1, 0);
    for (int64_t t = 0; t < T; ++t) {
      const float k = cl.data[size_t(t)];
      if (!(k >= 0 && k < float(m_K) && k == std::floor(k)))
        throw Error("compressed BTF (tensor): texel " + std::to_string(t) + " names cluster " +
                    std::to_string(k) + " of " + std::to_string(m_K));
      m_texCluster[size_t(t)] = int(k);
      int64_t n = 0;
      for (int ch = 0; ch < 3; ++ch) n += m_r[ch][size_t(k)].t;
      m_texOffset[size_t(t) + 1] = m_texOffset[size_t(t)] + n;
    }
    m_coef = &checked("coef", m_texOffset.back());
    {
      const auto params = nlohmann::json::parse(m_c.paramsJson, nullptr, false);
      if (params.is_object() && params.value("halfway", false))
        m_half = std::make_unique<HalfwayMap>(*m_dirs);
    }
    // Per-texel Rv × Rl matrices M = Σ_j coef_j core_j, when they fit in 256 MiB (one value is
    // then Rv·Rl products instead of Rt·Rv·Rl).
    int64_t mSize = 0;
    m_texM.resize(size_t(T) + 1, 0);
    for (int64_t t = 0; t < T; ++t) {
      m_texM[size_t(t)] = mSize;
      for (int ch = 0; ch < 3; ++ch) {
        const Ranks& r = m_r[ch][size_t(m_texCluster[size_t(t)])];
        mSize += int64_t(r.v) * r.l;
      }
    }
    m_texM[size_t(T)] = mSize;
    if (uint64_t(mSize) * 4 <= (uint64_t(256) << 20)) {
      m_M.resize(size_t(mSize));
      parallelForChunks(T, 64, [&](int64_t b, int64_t e) {
        for (int64_t t = b; t < e; ++t) {
          float* dst = m_M.data() + m_texM[size_t(t)];
          for (int ch = 0; ch < 3; ++ch) dst = texelMatrix(ch, t, dst);
        }
      });
    }
    // Per (cluster, view) the core projected on the view's factor row, W_j = xᵀ core_j (Rt × Rl),
    // when every cluster's fit in 256 MiB: one value is then Rt·Rl products (u · (W y)) instead
    // of Rv·Rl — random access and the renderer's lookups.
    // Built when it fits in 256 MiB and costs at most 2·10⁹ multiply-adds (~1 s on 2 cores).
    uint64_t wSize = 0, wCost = 0;
    for (int ch = 0; ch < 3; ++ch)
      for (int k = 0; k < m_K; ++k) {
        m_offW[ch].push_back(int64_t(wSize));
        const Ranks& r = m_r[ch][size_t(k)];
        wSize += uint64_t(m_n) * uint64_t(r.t) * uint64_t(r.l);
        wCost += uint64_t(m_n) * uint64_t(r.t) * uint64_t(r.l) * uint64_t(r.v);
      }
    if (projected && wSize * 4 <= (uint64_t(256) << 20) && wCost <= uint64_t(2000000000)) {
      m_Wall.resize(size_t(wSize));
      parallelForChunks(int64_t(m_K) * m_n, 16, [&](int64_t b, int64_t e) {
        for (int64_t kv = b; kv < e; ++kv) {
          const int k = int(kv / m_n), v = int(kv % m_n);
          for (int ch = 0; ch < 3; ++ch) {
            const Ranks& r = m_r[ch][size_t(k)];
            const int64_t d = int64_t(r.v) * r.l;
            const float* x = m_view[ch]->data.data() + m_offV[ch][size_t(k)] + int64_t(v) * r.v;
            const float* core = m_core[ch]->data.data() + m_offC[ch][size_t(k)];
            float* W = m_Wall.data() + m_offW[ch][size_t(k)] + int64_t(v) * r.t * r.l;
            for (int j = 0; j < r.t; ++j)
              for (int q = 0; q < r.l; ++q) {
                double acc = 0;
                for (int i = 0; i < r.v; ++i)
                  acc += double(x[i]) * core[int64_t(j) * d + int64_t(i) * r.l + q];
                W[int64_t(j) * r.l + q] = float(acc);
              }
          }
        }
      });
    }
  }
  std::string kind() const override { return "tensor"; }

  TensorGpuTables gpuTables(uint64_t maxMatrixFloats) const {
    TensorGpuTables g;
    const int64_t T = m_info.texels();
    // Per (channel, cluster, view, light) the core projected on both factor rows,
    // G[(v·n + l)·Rt + j] = x_vᵀ core_j y_l: a value is then Rt products of the texel's
    // coefficients (what the shader does when they fit, instead of Rv·Rl per texel matrix).
    uint64_t gFloats = 0;
    std::vector<int64_t> gOff[3];
    for (int ch = 0; ch < 3; ++ch)
      for (int k = 0; k < m_K; ++k) {
        const Ranks& r = m_r[ch][size_t(k)];
        gOff[ch].push_back(r.t > 0 ? int64_t(gFloats) : -1);
        gFloats += uint64_t(m_n) * uint64_t(m_n) * uint64_t(r.t);
      }
    const bool withG = gFloats <= std::min<uint64_t>(maxMatrixFloats, uint64_t(1) << 24) &&
                       m_texOffset.back() <= (int64_t(1) << 24);
    g.projected = withG;
    if (withG) {
      g.matrices.assign(size_t(gFloats), 0.f);
      parallelForChunks(int64_t(3) * m_K * m_n, 8, [&](int64_t b, int64_t e) {
        std::vector<double> W;
        for (int64_t i = b; i < e; ++i) {
          const int ch = int(i / (int64_t(m_K) * m_n)), k = int(i / m_n % m_K), v = int(i % m_n);
          const Ranks& r = m_r[ch][size_t(k)];
          if (r.t == 0) continue;
          const int64_t d = int64_t(r.v) * r.l;
          const float* x = m_view[ch]->data.data() + m_offV[ch][size_t(k)] + int64_t(v) * r.v;
          const float* core = m_core[ch]->data.data() + m_offC[ch][size_t(k)];
          W.assign(size_t(r.t) * size_t(r.l), 0.0);  // xᵀ core_j, Rt × Rl
          for (int j = 0; j < r.t; ++j)
            for (int a = 0; a < r.v; ++a)
              for (int q = 0; q < r.l; ++q)
                W[size_t(j) * r.l + q] +=
                    double(x[a]) * core[int64_t(j) * d + int64_t(a) * r.l + q];
          for (int l = 0; l < m_n; ++l) {
            const float* y = m_light[ch]->data.data() + m_offL[ch][size_t(k)] + int64_t(l) * r.l;
            float* dst =
                g.matrices.data() + gOff[ch][size_t(k)] + (int64_t(v) * m_n + l) * int64_t(r.t);
            for (int j = 0; j < r.t; ++j) {
              double acc = 0;
              for (int q = 0; q < r.l; ++q) acc += W[size_t(j) * r.l + q] * double(y[q]);
              dst[j] = float(acc);
            }
          }
        }
      });
    }
    const uint64_t mFloats = uint64_t(m_texM.back());
    const bool withM = !withG &&
                       mFloats <= std::min<uint64_t>(maxMatrixFloats, uint64_t(1) << 24) &&
                       m_texOffset.back() <= (int64_t(1) << 24);
    std::vector<float> tmp;
    for (int64_t t = 0; t < T; ++t) {
      g.texels.push_back(float(m_texCluster[size_t(t)]));
      g.texels.push_back(float(m_texOffset[size_t(t)]));
      g.texels.push_back(withM ? float(m_texM[size_t(t)]) : -1.f);
      if (withM) {
        const float* M = matrices(t, tmp);
        g.matrices.insert(g.matrices.end(), M, M + (m_texM[size_t(t) + 1] - m_texM[size_t(t)]));
      }
    }
    for (int ch = 0; ch < 3; ++ch)
      for (int k = 0; k < m_K; ++k) {
        const Ranks& r = m_r[ch][size_t(k)];
        for (int64_t x : {int64_t(r.v), int64_t(r.l), int64_t(r.t), m_offV[ch][size_t(k)],
                          m_offL[ch][size_t(k)], m_offC[ch][size_t(k)],
                          withG ? gOff[ch][size_t(k)] : int64_t(-1)})
          g.clusters[ch].push_back(float(x));
      }
    return g;
  }

  void texel(int64_t t, float* out) const override {
    if (!m_half) return texelStored(t, out);
    std::vector<float> hw(size_t(m_n) * m_n * 3);
    texelStored(t, hw.data());
    m_half->inverse(hw.data(), out);
  }

  std::array<float, 3> value(int64_t t, int view, int light) const override {
    if (!m_half) return valueStored(t, view, light);
    DirWeight w[4];
    const int n = m_half->inverseTaps(view, light, w);
    std::array<float, 3> out{0, 0, 0};
    for (int i = 0; i < n; ++i) {
      const std::array<float, 3> x = valueStored(t, view, w[i].index);
      for (int c = 0; c < 3; ++c) out[size_t(c)] += float(w[i].weight) * x[size_t(c)];
    }
    return out;
  }

  bool halfway() const { return m_half != nullptr; }

 private:
  // The stored model's values: in half-vector coordinates with --halfway.
  void texelStored(int64_t t, float* out) const {
    la::MatF V[3];
    std::vector<float> tmp;
    const int k = m_texCluster[size_t(t)];
    const float* Mt = matrices(t, tmp);
    for (int ch = 0; ch < 3; ++ch) {
      const Ranks& r = m_r[ch][size_t(k)];
      if (r.t == 0) {
        V[ch] = la::MatF::Zero(m_n, m_n);
        Mt += int64_t(r.v) * r.l;
        continue;
      }
      const Eigen::Map<const RowMat> Uv(m_view[ch]->data.data() + m_offV[ch][size_t(k)], m_n, r.v);
      const Eigen::Map<const RowMat> Ul(m_light[ch]->data.data() + m_offL[ch][size_t(k)], m_n, r.l);
      const Eigen::Map<const RowMat> M(Mt, r.v, r.l);
      V[ch] = (Uv * M) * Ul.transpose();
      Mt += int64_t(r.v) * r.l;
    }
    for (int v = 0; v < m_n; ++v)
      for (int l = 0; l < m_n; ++l) {
        const float in[3] = {V[0](v, l), V[1](v, l), V[2](v, l)};
        fromColour(m_c.colour, in, out + (size_t(v) * m_n + l) * 3);
      }
  }

  std::array<float, 3> valueStored(int64_t t, int view, int light) const {
    std::vector<float> tmp;
    const int k = m_texCluster[size_t(t)];
    const float* Mt = m_Wall.empty() ? matrices(t, tmp) : nullptr;
    float in[3] = {0, 0, 0};
    for (int ch = 0; ch < 3; ++ch) {
      const Ranks& r = m_r[ch][size_t(k)];
      if (r.t > 0) {
        const float* x = m_view[ch]->data.data() + m_offV[ch][size_t(k)] + int64_t(view) * r.v;
        const float* y = m_light[ch]->data.data() + m_offL[ch][size_t(k)] + int64_t(light) * r.l;
        const Eigen::Map<const la::VecF> yv(y, r.l);
        float acc = 0;
        if (!m_Wall.empty()) {
          // u · (W y): the texel's Rt coefficients against the view's projected core.
          int64_t o = m_texOffset[size_t(t)];
          for (int q = 0; q < ch; ++q) o += m_r[q][size_t(k)].t;
          const float* u = m_coef->data.data() + o;
          const float* W = m_Wall.data() + m_offW[ch][size_t(k)] + int64_t(view) * r.t * r.l;
          for (int j = 0; j < r.t; ++j)
            acc += u[j] * Eigen::Map<const la::VecF>(W + int64_t(j) * r.l, r.l).dot(yv);
        } else {
          // xᵀ (M y) in float (the GLSL decoder's arithmetic), row by row: each row's dot
          // product vectorised, no temporary vector.
          for (int i = 0; i < r.v; ++i)
            acc += x[i] * Eigen::Map<const la::VecF>(Mt + int64_t(i) * r.l, r.l).dot(yv);
        }
        in[ch] = acc;
      }
      if (Mt) Mt += int64_t(r.v) * r.l;
    }
    std::array<float, 3> rgb{};
    fromColour(m_c.colour, in, rgb.data());
    return rgb;
  }

  const CArray& checked(const std::string& name, int64_t rows) const {
    const CArray& a = m_c.array(name);
    if (a.rows != rows || a.cols != 1)
      throw Error("compressed BTF (tensor): array '" + name + "' is " + std::to_string(a.rows) +
                  " × " + std::to_string(a.cols) + ", its ranks need " + std::to_string(rows) +
                  " × 1");
    return a;
  }
  // Channel ch's M (Rv × Rl, row-major) of texel t written at dst; returns the end.
  float* texelMatrix(int ch, int64_t t, float* dst) const {
    const int k = m_texCluster[size_t(t)];
    const Ranks& r = m_r[ch][size_t(k)];
    const int64_t d = int64_t(r.v) * r.l;
    int64_t o = m_texOffset[size_t(t)];
    for (int q = 0; q < ch; ++q) o += m_r[q][size_t(k)].t;
    const float* u = m_coef->data.data() + o;
    const float* core = m_core[ch]->data.data() + m_offC[ch][size_t(k)];
    for (int64_t q = 0; q < d; ++q) {
      double s = 0;
      for (int j = 0; j < r.t; ++j) s += double(u[j]) * core[int64_t(j) * d + q];
      dst[q] = float(s);
    }
    return dst + d;
  }
  const float* matrices(int64_t t, std::vector<float>& tmp) const {
    if (!m_M.empty() || m_texM.back() == 0) return m_M.data() + m_texM[size_t(t)];
    tmp.resize(size_t(m_texM[size_t(t) + 1] - m_texM[size_t(t)]));
    float* dst = tmp.data();
    for (int ch = 0; ch < 3; ++ch) dst = texelMatrix(ch, t, dst);
    return tmp.data();
  }

  CompressedBtf m_c;
  int m_n = 0, m_K = 0;
  std::vector<Ranks> m_r[3];
  std::vector<int64_t> m_offV[3], m_offL[3], m_offC[3];
  const CArray *m_view[3], *m_light[3], *m_core[3], *m_coef = nullptr;
  std::vector<int> m_texCluster;
  std::vector<int64_t> m_texOffset, m_texM;
  std::vector<float> m_M;
  std::vector<int64_t> m_offW[3];      // per channel and cluster: offset of its views' W blocks
  std::vector<float> m_Wall;           // every W block (empty: over the budget)
  std::unique_ptr<HalfwayMap> m_half;  // the stored model is in half-vector coordinates
};

}  // namespace

std::unique_ptr<Decoder> makeTensorDecoder(CompressedBtf c) {
  return std::make_unique<TensorDecoder>(std::move(c));
}

TensorGpuTables tensorGpuTables(const CompressedBtf& c, uint64_t maxMatrixFloats) {
  if (c.codec != "tensor") throw Error("tensor tables of a '" + c.codec + "' file");
  const auto params = nlohmann::json::parse(c.paramsJson, nullptr, false);
  if (params.is_object() && params.value("halfway", false))
    throw Error(
        "tensor tables: a file in half-vector coordinates (--halfway) has no GPU decoder "
        "(docs/compression.md)");
  if (!c.levels.empty()) {
    // A pyramid: the tables of every level's texels, level 0's first (what a shader indexing
    // texels u + Nu·v reads).
    return TensorDecoder(asStrip(c), false).gpuTables(maxMatrixFloats);
  }
  return TensorDecoder(c, false).gpuTables(maxMatrixFloats);
}

}  // namespace btf
