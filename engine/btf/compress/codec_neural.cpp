// The neural codec (docs/compression.md, "neural"; after Rainer et al. 2019 and NeuMIP,
// Kuznetsov et al. 2021): per texel a short latent vector z_t, and one decoder network shared by
// the whole material that maps (z_t, features(ω_i, ω_o)) to the texel's aBRDF in the colour
// model divided by its gain g_t (the texel's RMS) — so a file is evaluated at any pair of
// directions, not only at the set's, a texel's brightness never costs the network accuracy
// (a dynamic range of 1e9 over the tile is fine), and an all-zero texel decodes to exact zeros.
//
// Training (train): the decoder and the training texels' latents together, by Adam over random
// (texel, direction pair) samples of the stratified training subset. Encoding (add): each
// texel's latent alone, the decoder frozen, by Levenberg–Marquardt from the latent of the
// training texel nearest on a fixed set of probe pairs — texel by texel, so any chunking of the
// stream, any thread count and a cluster job write the same bytes.
//
// Arrays: neural.weights (1 × P, f32): the network (neural_net.h's layout; layer 0's columns are
// the latent's L first, then the D direction features); neural.latents (texels × L);
// neural.gain (texels × 1, f32). value_c(t, ω_i, ω_o) = g_t · max(0, cos θ_i) ·
// net(z_t, features(ω_i, ω_o))_c: the factor cos θ_i an aBRDF carries is not left to the network.
// Params: latent, hidden, hidden_layers, encoding ("halfdiff": ω_i, ω_o, the half vector and ω_i
// in the half vector's frame, 12 features; "raw": ω_i, ω_o, 6).
#include <btf/core/error.h>
#include <btf/core/format.h>
#include <btf/core/math.h>
#include <btf/core/progress.h>
#include <btf/core/rng.h>
#include <btf/core/run_context.h>
#include <btf/directions/direction_set.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "codec.h"
#include "neural_net.h"

namespace btf {
namespace {

using nn::Mat;
using nn::Vec;

constexpr int kMaxLatentFromTarget = 16;  // a target never asks for more (explicit: up to 64)
constexpr int kBatch = 4096, kShards = 8;  // samples per Adam step, fixed shards of it
constexpr int kProbes = 256;               // pairs on which a texel finds its nearest start
constexpr int kFitPairs = 4096;            // pairs a texel's latent is fitted on (at most)
constexpr int kFitIterations = 12;

int featureCount(const std::string& encoding) {
  return encoding == "raw" ? 6 : encoding == "fourier" ? 36 : 12;
}

/// The network's direction input for light ω_i and view ω_o (local frame, z the normal).
/// `minimal`: ω_i is carried into the half vector's frame by the rotation that takes h to z about
/// h × z (files written from 2026-12-07, params.half_frame "minimal"); else by Rusinkiewicz's
/// rotations, −φ_h about z then −θ_h about y (the earlier files). The two differ by a rotation of
/// φ_h about z; Rusinkiewicz's frame is discontinuous where h meets the normal (φ_h is then
/// arbitrary, so at the mirror pair — the highlight — the feature follows rounding noise), the
/// minimal rotation tends to the identity there whatever φ_h.
void features(const std::string& encoding, const DVec3& wi, const DVec3& wo, float* f,
              bool minimal) {
  f[0] = float(wi.x), f[1] = float(wi.y), f[2] = float(wi.z);
  f[3] = float(wo.x), f[4] = float(wo.y), f[5] = float(wo.z);
  if (encoding == "raw") return;
  DVec3 h = wi + wo;
  const double len = glm::length(h);
  h = len > 1e-9 ? h / len : DVec3(0, 0, 1);
  f[6] = float(h.x), f[7] = float(h.y), f[8] = float(h.z);
  // ω_i in the half vector's frame (Rusinkiewicz's difference vector): rotate by −φ_h about z,
  // then by −θ_h about y.
  const double th = std::acos(std::clamp(h.z, -1.0, 1.0)), ph = std::atan2(h.y, h.x);
  const double cp = std::cos(ph), sp = std::sin(ph), ct = std::cos(th), st = std::sin(th);
  const double x = wi.x * cp + wi.y * sp, y = -wi.x * sp + wi.y * cp, z = wi.z;
  const double dx = x * ct - z * st, dy = y, dz = x * st + z * ct;
  if (minimal)  // and back by φ_h about z
    f[9] = float(dx * cp - dy * sp), f[10] = float(dx * sp + dy * cp), f[11] = float(dz);
  else
    f[9] = float(dx), f[10] = float(dy), f[11] = float(dz);
  if (encoding != "fourier") return;
  // Fourier features of the twelve (Tancik et al. 2020): sin and cos of π · each.
  for (int i = 0; i < 12; ++i) {
    f[12 + 2 * i] = float(std::sin(M_PI * f[i]));
    f[13 + 2 * i] = float(std::cos(M_PI * f[i]));
  }
}

struct Shape {
  int latent = 8, hidden = 32, hiddenLayers = 2;
  std::string encoding = "halfdiff";
  bool minimalFrame = true;  // features(): false only for files before params.half_frame
  std::vector<int> sizes() const {
    std::vector<int> s{latent + featureCount(encoding)};
    for (int i = 0; i < hiddenLayers; ++i) s.push_back(hidden);
    s.push_back(3);
    return s;
  }
};

/// The set's features, one column per pair k = view · nL + light.
Mat pairFeatures(const DirectionSet& d, const std::string& encoding, bool minimal) {
  const int n = d.size(), D = featureCount(encoding);
  Mat F(D, int64_t(n) * n);
  std::vector<float> f(static_cast<size_t>(D));
  for (int v = 0; v < n; ++v)
    for (int l = 0; l < n; ++l) {
      features(encoding, d[l].w, d[v].w, f.data(), minimal);
      for (int i = 0; i < D; ++i) F(i, int64_t(v) * n + l) = f[size_t(i)];
    }
  return F;
}

/// Layer 0's direction part plus its bias at every pair: H × pairs.
Mat pairTerms(const nn::Net& net, int latent, const Mat& F) {
  const auto W = net.W(0);
  Mat P = W.rightCols(W.cols() - latent) * F;
  P.colwise() += net.b(0);
  return P;
}

/// The factor of the light's cosine (feature 2 is ω_i.z in both encodings).
inline float lightCosine(float z) {
  return std::max(0.f, z);
}

/// Network outputs (3 × n) for one latent over a block of layer-0 direction terms.
void decodeBlock(const nn::Net& net, int latent, const float* z, const Mat& terms, nn::Pass& p,
                 Mat& a0) {
  const Vec c = net.W(0).leftCols(latent) * Eigen::Map<const Vec>(z, latent);
  a0 = terms.colwise() + c;
  forward(net, Mat(), p, &a0);
}

// ------------------------------------------------------------------ encoder

class NeuralEncoder final : public Encoder {
 public:
  NeuralEncoder(const CodecSettings& s, const BtfInfo& info, const CancelToken* cancel)
      : m_s(s), m_info(info), m_cancel(cancel), m_dirs(DirectionSet::fromName(info.directionSet)) {
    m_n = info.nDirs();
    m_pairs = int64_t(m_n) * m_n;
    m_shape.hidden = s.neuralHidden;
    m_shape.hiddenLayers = s.neuralLayers;
    m_shape.encoding = s.neuralEncoding;
    m_shape.latent = chooseLatent();
    m_train = stratifiedTexels(info.nu, info.nv, s.trainTexels, s.seed);
    m_latents.assign(size_t(info.texels()) * size_t(m_shape.latent), 0.f);
    m_gain.assign(size_t(info.texels()), 0.f);
    m_done.assign(size_t(info.texels()), 0);
    for (int i = 0; i < kProbes; ++i)
      m_probe.push_back(int64_t(hashKeys(s.seed, uint64_t(i), 0x70726f) % uint64_t(m_pairs)));
  }
  void setProgress(bool on) override { m_progress = on; }
  std::vector<int64_t> trainingTexels() const override { return m_train; }
  uint64_t memoryBytes() const override {
    const uint64_t H = uint64_t(m_s.neuralHidden), D = uint64_t(featureCount(m_s.neuralEncoding));
    return uint64_t(m_pairs) * (H + D) * 4 + m_latents.size() * 4 + m_gain.size() * 4 +
           uint64_t(m_train.size()) * (kProbes * 3 + uint64_t(m_shape.latent) * 3) * 4 +
           uint64_t(kBatch) * (H * uint64_t(m_shape.hiddenLayers) * 3 + 64) * 4 * 2;
  }

  void train(const float* values) override {
    const int64_t T = int64_t(m_train.size());
    const int L = m_shape.latent;
    const size_t stride = size_t(m_pairs) * 3;
    m_features = pairFeatures(m_dirs, m_shape.encoding, m_shape.minimalFrame);
    const int D = int(m_features.rows());
    // Gains: each training texel's RMS in the colour model.
    std::vector<double> sq(size_t(T), 0.0);
    parallelForChunks(T, 1, [&](int64_t b, int64_t e) {
      for (int64_t i = b; i < e; ++i) {
        double acc = 0;
        for (int64_t k = 0; k < m_pairs; ++k) {
          float c[3];
          toColour(m_s.colour, values + size_t(i) * stride + size_t(k) * 3, c);
          acc += double(c[0]) * c[0] + double(c[1]) * c[1] + double(c[2]) * c[2];
        }
        sq[size_t(i)] = acc;
      }
    });
    std::vector<float> inv(size_t(T), 0.f);
    std::vector<int64_t> lit;  // training texels that are not all zero
    for (int64_t i = 0; i < T; ++i) {
      const float g = gainOf(sq[size_t(i)]);
      if (g > 0) inv[size_t(i)] = 1.f / g, lit.push_back(i);
    }
    auto target = [&](int64_t i, int64_t k, float* y) {
      toColour(m_s.colour, values + size_t(i) * stride + size_t(k) * 3, y);
      for (int c = 0; c < 3; ++c) y[c] = std::isfinite(y[c]) ? y[c] * inv[size_t(i)] : 0.f;
    };

    m_net.sizes = m_shape.sizes();
    m_net.init(m_s.seed);
    const size_t P = m_net.params.size();
    std::vector<float> Z(size_t(T) * L);
    for (size_t i = 0; i < Z.size(); ++i)
      Z[i] = 0.1f * (uniformFloat(hashKeys(m_s.seed, i, 0x7a)) - 0.5f);
    nn::Adam adamW, adamZ;
    const int steps = lit.empty() ? 0 : m_s.neuralSteps, per = kBatch / kShards;
    std::vector<std::vector<float>> gW(kShards), gZ(kShards);
    std::vector<double> loss(kShards);
    ProgressReporter pr("train neural", steps, m_progress);
    for (int step = 0; step < steps; ++step) {
      if (m_cancel && m_cancel->cancelled()) throw Cancelled("compression");
      parallelForChunks(kShards, 1, [&](int64_t j0, int64_t j1) {
        nn::Pass p;
        Mat X(L + D, per), Y(3, per), dx;
        Eigen::RowVectorXf cw(per);
        std::vector<int64_t> who(static_cast<size_t>(per));
        for (int64_t j = j0; j < j1; ++j) {
          for (int i = 0; i < per; ++i) {
            const uint64_t h = hashKeys(m_s.seed, uint64_t(step), uint64_t(j * per + i), 0x7472);
            const int64_t ti = lit[size_t((h >> 32) % uint64_t(lit.size()))];
            const int64_t k = int64_t(h % uint64_t(m_pairs));
            who[size_t(i)] = ti;
            for (int q = 0; q < L; ++q) X(q, i) = Z[size_t(ti) * L + size_t(q)];
            X.block(L, i, D, 1) = m_features.col(k);
            cw(i) = lightCosine(m_features(2, k));
            float y[3];
            target(ti, k, y);
            Y(0, i) = y[0], Y(1, i) = y[1], Y(2, i) = y[2];
          }
          forward(m_net, X, p);
          const Mat r = (p.a.back().array().rowwise() * cw.array()).matrix() - Y;
          loss[size_t(j)] = double(r.squaredNorm());
          const Mat dOut = (r.array().rowwise() * cw.array()).matrix() * (2.f / float(kBatch));
          gW[size_t(j)].assign(P, 0.f);
          gZ[size_t(j)].assign(Z.size(), 0.f);
          backward(m_net, p, dOut, gW[size_t(j)].data(), &dx);
          for (int i = 0; i < per; ++i)
            for (int q = 0; q < L; ++q) gZ[size_t(j)][size_t(who[size_t(i)]) * L + q] += dx(q, i);
        }
      });
      std::vector<float> g = gW[0], gz = gZ[0];
      double ls = loss[0];
      for (int j = 1; j < kShards; ++j) {
        for (size_t i = 0; i < P; ++i) g[i] += gW[size_t(j)][i];
        for (size_t i = 0; i < gz.size(); ++i) gz[i] += gZ[size_t(j)][i];
        ls += loss[size_t(j)];
      }
      // Cosine decay from lr0 to lr0 / 100.
      const double cosine = 0.5 * (1 + std::cos(M_PI * double(step) / std::max(1, steps - 1)));
      const float lr = float(m_s.neuralRate * (0.01 + 0.99 * cosine));
      adamW.step(m_net.params.data(), g.data(), P, lr);
      adamZ.step(Z.data(), gz.data(), Z.size(), lr);
      m_lastLoss = ls / (3.0 * kBatch);
      pr.add(1);
    }
    if (m_cancel && m_cancel->cancelled()) throw Cancelled("compression");
    pr.finish();
    // Quantize the weights now (f32 is what the file holds: nothing to round); the pair terms
    // and the training texels' probes for the encoding pass.
    for (float& w : m_net.params)
      if (!std::isfinite(w)) throw Error("neural encoder: training diverged (a weight is not finite)");
    m_terms = pairTerms(m_net, L, m_features);
    m_trainZ = std::move(Z);
    m_trainProbe.assign(size_t(T) * kProbes * 3, 0.f);
    m_trainLit.assign(size_t(T), 0);
    for (int64_t i : lit) m_trainLit[size_t(i)] = 1;
    for (int64_t i = 0; i < T; ++i)
      for (int q = 0; q < kProbes; ++q) target(i, m_probe[size_t(q)], &m_trainProbe[(size_t(i) * kProbes + q) * 3]);
    m_trainRel = trainingError(values, inv, lit);
    m_trained = true;
  }

  void add(int64_t t0, int64_t t1, const float* values) override {
    if (!m_trained) throw Error("neural encoder: add() before train()");
    const size_t stride = size_t(m_pairs) * 3;
    parallelForChunks(
        t1 - t0, 1,
        [&](int64_t b, int64_t e) {
          for (int64_t i = b; i < e; ++i) {
            fitTexel(t0 + i, values + size_t(i) * stride);
            m_done[size_t(t0 + i)] = 1;
          }
        },
        m_cancel);
    if (m_cancel && m_cancel->cancelled()) throw Cancelled("compression");
  }

  std::string addedState() const override {
    StateWriter w;
    const size_t L = size_t(m_shape.latent);
    for (int64_t t = 0; t < int64_t(m_done.size()); ++t) {
      if (!m_done[size_t(t)]) continue;
      w.put<int64_t>(t);
      w.putVector(std::vector<float>(m_latents.begin() + ptrdiff_t(size_t(t) * L),
                                     m_latents.begin() + ptrdiff_t(size_t(t + 1) * L)));
      w.put<float>(m_gain[size_t(t)]);
    }
    return w.take();
  }
  void mergeAdded(const std::string& bytes) override {
    if (!m_trained) throw Error("neural encoder: mergeAdded() before train()");
    StateReader r(bytes);
    const size_t L = size_t(m_shape.latent);
    while (!r.done()) {
      const int64_t t = r.get<int64_t>();
      if (t < 0 || t >= int64_t(m_done.size())) throw Error("encoder state: texel out of range");
      const std::vector<float> row = r.getVector<float>(L);
      if (row.size() != L) throw Error("encoder state: row size mismatch");
      std::copy(row.begin(), row.end(), m_latents.begin() + ptrdiff_t(size_t(t) * L));
      m_gain[size_t(t)] = r.get<float>();
      m_done[size_t(t)] = 1;
    }
  }

  CompressedBtf finish() override {
    for (size_t t = 0; t < m_done.size(); ++t)
      if (!m_done[t])
        throw Error("neural encoder: texel " + std::to_string(t) + " was never added");
    CompressedBtf out;
    out.info = m_info;
    out.codec = "neural";
    out.colour = m_s.colour;
    CArray& w = out.add("neural.weights", ArrayType::F32, 1, int64_t(m_net.params.size()));
    w.data = m_net.params;
    CArray& z = out.add("neural.latents", m_s.half ? ArrayType::F16 : ArrayType::F32,
                        m_info.texels(), m_shape.latent);
    z.data = m_latents;
    CArray& g = out.add("neural.gain", ArrayType::F32, m_info.texels(), 1);
    g.data = m_gain;
    out.quantize();
    nlohmann::ordered_json params = nlohmann::ordered_json::parse(settingsJson(m_s));
    params["latent"] = m_shape.latent;
    params["hidden"] = m_shape.hidden;
    params["hidden_layers"] = m_shape.hiddenLayers;
    params["encoding"] = m_shape.encoding;
    params["half_frame"] = "minimal";
    params["training_texels"] = m_train.size();
    out.paramsJson = params.dump();
    nlohmann::ordered_json st;
    st["training_relative_rmse"] = m_trainRel;
    if (!m_latentNote.empty()) st["ratio_limit"] = m_latentNote;
    out.statsJson = st.dump();
    return out;
  }

 private:
  // Relative RMSE of the trained network on 64 Ki fixed (training texel, pair) samples, each
  // texel weighted by its gain² (what compare measures over the tile).
  double trainingError(const float* values, const std::vector<float>& inv,
                       const std::vector<int64_t>& lit) const {
    if (lit.empty()) return 0;
    const int L = m_shape.latent, D = int(m_features.rows()), per = 4096, blocks = 16;
    const size_t stride = size_t(m_pairs) * 3;
    std::vector<double> err(blocks), ref(blocks);
    parallelForChunks(blocks, 1, [&](int64_t b0, int64_t b1) {
      nn::Pass p;
      Mat X(L + D, per), Y(3, per);
      Eigen::RowVectorXf cw(per);
      std::vector<double> w(static_cast<size_t>(per));
      for (int64_t b = b0; b < b1; ++b) {
        for (int i = 0; i < per; ++i) {
          const uint64_t h = hashKeys(m_s.seed, uint64_t(b), uint64_t(i), 0x6576);
          const int64_t ti = lit[size_t((h >> 32) % uint64_t(lit.size()))];
          const int64_t k = int64_t(h % uint64_t(m_pairs));
          for (int q = 0; q < L; ++q) X(q, i) = m_trainZ[size_t(ti) * L + size_t(q)];
          X.block(L, i, D, 1) = m_features.col(k);
          cw(i) = lightCosine(m_features(2, k));
          float y[3];
          toColour(m_s.colour, values + size_t(ti) * stride + size_t(k) * 3, y);
          for (int c = 0; c < 3; ++c) Y(c, i) = std::isfinite(y[c]) ? y[c] * inv[size_t(ti)] : 0.f;
          w[size_t(i)] = 1.0 / (double(inv[size_t(ti)]) * inv[size_t(ti)]);
        }
        forward(m_net, X, p);
        double e = 0, r = 0;
        for (int i = 0; i < per; ++i) {
          e += w[size_t(i)] * double((p.a.back().col(i) * cw(i) - Y.col(i)).squaredNorm());
          r += w[size_t(i)] * double(Y.col(i).squaredNorm());
        }
        err[size_t(b)] = e, ref[size_t(b)] = r;
      }
    });
    double e = 0, r = 0;
    for (int b = 0; b < blocks; ++b) e += err[size_t(b)], r += ref[size_t(b)];
    return r > 0 ? std::sqrt(e / r) : 0;
  }

  // A texel's gain from its sum of squares: its RMS, rounded to f32; 0 when (almost) all zero.
  float gainOf(double sumSquares) const {
    const double rms = std::sqrt(sumSquares / (double(m_pairs) * 3));
    return std::isfinite(rms) && rms > 1e-30 ? float(rms) : 0.f;
  }

  int chooseLatent() {
    if (m_s.components > 0) return m_s.components;
    if (m_s.targetRatio > 0) {
      // Bytes: header (~64 KiB allowance, as the other codecs), the weights, texels × L.
      Shape probe;
      probe.hidden = m_s.neuralHidden, probe.hiddenLayers = m_s.neuralLayers;
      probe.encoding = m_s.neuralEncoding, probe.latent = kMaxLatentFromTarget;
      const double raw = double(m_info.texels()) * double(m_pairs) * 12.0;
      const double budget = raw / m_s.targetRatio - 65536.0 -
                            4.0 * double(nn::Net::paramCount(probe.sizes()));
      const double per = double(m_info.texels()) * (m_s.half ? 2 : 4);
      const int L = int(std::floor(budget / per));
      if (L > kMaxLatentFromTarget) {
        m_latentNote = format("1:%g leaves room for %d latent values per texel; the codec keeps "
                              "%d (--components sets more), so the file is smaller than asked",
                              m_s.targetRatio, L, kMaxLatentFromTarget);
        return kMaxLatentFromTarget;
      }
      if (L < 1) {
        m_latentNote = format("1:%g leaves no room for one latent value per texel beside the "
                              "decoder: the file keeps 1 and is larger than asked",
                              m_s.targetRatio);
        return 1;
      }
      return L;
    }
    return m_s.targetRmse > 0 ? kMaxLatentFromTarget : 8;
  }

  // The latent of texel t (values: its pairs × RGB), the decoder frozen.
  void fitTexel(int64_t t, const float* values) {
    const int L = m_shape.latent;
    double sq = 0;
    for (int64_t k = 0; k < m_pairs; ++k) {
      float c[3];
      toColour(m_s.colour, values + size_t(k) * 3, c);
      for (float x : c) sq += std::isfinite(x) ? double(x) * x : 0.0;
    }
    const float gain = gainOf(sq);
    m_gain[size_t(t)] = gain;
    if (gain == 0) {  // all zero: the gain alone decodes it
      std::fill_n(m_latents.begin() + ptrdiff_t(size_t(t) * L), L, 0.f);
      return;
    }
    const float inv = 1.f / gain;
    auto target = [&](int64_t k, float* y) {
      toColour(m_s.colour, values + size_t(k) * 3, y);
      for (int c = 0; c < 3; ++c) y[c] = std::isfinite(y[c]) ? y[c] * inv : 0.f;
    };
    // Start: the training latent nearest on the probe pairs.
    std::vector<float> probe(size_t(kProbes) * 3);
    for (int q = 0; q < kProbes; ++q) target(m_probe[size_t(q)], &probe[size_t(q) * 3]);
    size_t best = m_train.size();
    double bd = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < m_train.size(); ++i) {
      if (!m_trainLit[i]) continue;
      double d = 0;
      const float* p = &m_trainProbe[i * kProbes * 3];
      for (size_t q = 0; q < probe.size(); ++q) d += double(p[q] - probe[q]) * (p[q] - probe[q]);
      if (d < bd) bd = d, best = i;
    }
    Vec z = best < m_train.size() ? Vec(Eigen::Map<const Vec>(&m_trainZ[best * size_t(L)], L))
                                  : Vec(Vec::Zero(L));
    // The pairs it is fitted on: all of them, or kFitPairs drawn from (seed, t).
    const int64_t S = std::min<int64_t>(m_pairs, kFitPairs);
    Mat terms(m_terms.rows(), S), Y(3, S);
    Eigen::RowVectorXf cw(S);
    for (int64_t i = 0; i < S; ++i) {
      const int64_t k = S == m_pairs ? i : int64_t(hashKeys(m_s.seed, uint64_t(t), uint64_t(i), 0x6c6d) % uint64_t(m_pairs));
      terms.col(i) = m_terms.col(k);
      cw(i) = lightCosine(m_features(2, k));
      float y[3];
      target(k, y);
      Y(0, i) = y[0], Y(1, i) = y[1], Y(2, i) = y[2];
    }
    nn::Pass p;
    Mat a0;
    auto cost = [&](const Vec& zz) {
      decodeBlock(m_net, L, zz.data(), terms, p, a0);
      return double(((p.a.back().array().rowwise() * cw.array()).matrix() - Y).squaredNorm());
    };
    const int layers = m_net.layers();
    const Mat Wz = m_net.W(0).leftCols(L);
    double c0 = cost(z), lambda = 1e-3;
    for (int it = 0; it < kFitIterations; ++it) {
      // Jacobian of the three outputs with respect to z (reverse mode, one pass per output).
      const Mat r = (p.a.back().array().rowwise() * cw.array()).matrix() - Y;
      Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(L, L);
      Eigen::VectorXd Jtr = Eigen::VectorXd::Zero(L);
      for (int c = 0; c < 3; ++c) {
        Mat g = (p.a[size_t(layers) - 1].array() > 0.f).cast<float>().matrix();
        g = g.array().colwise() * m_net.W(layers - 1).row(c).transpose().array();
        for (int l = layers - 1; l >= 2; --l)
          g = (m_net.W(l - 1).transpose() * g).cwiseProduct(
              (p.a[size_t(l) - 1].array() > 0.f).cast<float>().matrix());
        const Mat J = ((Wz.transpose() * g).array().rowwise() * cw.array()).matrix();  // L × S
        JtJ += (J * J.transpose()).cast<double>();
        Jtr += (J * r.row(c).transpose()).cast<double>();
      }
      bool improved = false;
      for (int tries = 0; tries < 6 && !improved; ++tries) {
        Eigen::MatrixXd A = JtJ;
        for (int q = 0; q < L; ++q) A(q, q) += lambda * JtJ(q, q) + 1e-12;
        const Eigen::VectorXd step = A.ldlt().solve(-Jtr);
        const Vec cand = z + step.cast<float>();
        if (!cand.allFinite()) {
          lambda *= 10;
          continue;
        }
        const double c1 = cost(cand);
        if (c1 < c0) {
          improved = true;
          const double gain = (c0 - c1) / std::max(c0, 1e-30);
          z = cand, c0 = c1, lambda = std::max(1e-7, lambda / 3);
          if (gain < 1e-5) it = kFitIterations;  // converged
        } else {
          lambda *= 10;
        }
      }
      if (!improved) break;  // (p holds z's pass: the accepted candidate was the last cost)
    }
    std::copy(z.data(), z.data() + L, m_latents.begin() + ptrdiff_t(size_t(t) * L));
  }

  CodecSettings m_s;
  BtfInfo m_info;
  const CancelToken* m_cancel;
  DirectionSet m_dirs;
  int m_n = 0;
  int64_t m_pairs = 0;
  Shape m_shape;
  std::string m_latentNote;
  std::vector<int64_t> m_train, m_probe;
  std::vector<float> m_latents, m_gain, m_trainZ, m_trainProbe;
  std::vector<uint8_t> m_done, m_trainLit;
  nn::Net m_net;
  Mat m_features, m_terms;
  double m_lastLoss = 0, m_trainRel = 0;
  bool m_trained = false, m_progress = false;
};

// ------------------------------------------------------------------ decoder

class NeuralDecoder final : public Decoder {
 public:
  explicit NeuralDecoder(CompressedBtf c) : Decoder(c.info), m_c(std::move(c)) {
    const auto params = nlohmann::json::parse(m_c.paramsJson, nullptr, false);
    auto intParam = [&](const char* key, int lo, int hi) {
      if (!params.is_object() || !params.contains(key) || !params[key].is_number_integer())
        throw Error(std::string("compressed BTF (neural): params.") + key + " is missing");
      const int64_t v = params[key].get<int64_t>();
      if (v < lo || v > hi)
        throw Error(format("compressed BTF (neural): params.%s = %lld outside [%d, %d]", key,
                           (long long)v, lo, hi));
      return int(v);
    };
    m_shape.latent = intParam("latent", 1, 64);
    m_shape.hidden = intParam("hidden", 1, 256);
    m_shape.hiddenLayers = intParam("hidden_layers", 1, 8);
    if (!params.contains("encoding") || !params["encoding"].is_string() ||
        (params["encoding"] != "halfdiff" && params["encoding"] != "raw" &&
         params["encoding"] != "fourier"))
      throw Error("compressed BTF (neural): params.encoding must be halfdiff, fourier or raw");
    m_shape.encoding = params["encoding"].get<std::string>();
    if (params.contains("half_frame") &&
        !(params["half_frame"] == "minimal" || params["half_frame"] == "rusinkiewicz"))
      throw Error("compressed BTF (neural): params.half_frame must be minimal or rusinkiewicz");
    m_shape.minimalFrame = params.contains("half_frame") && params["half_frame"] == "minimal";
    m_net.sizes = m_shape.sizes();
    const CArray& w = m_c.array("neural.weights");
    if (w.rows != 1 || w.cols != nn::Net::paramCount(m_net.sizes))
      throw Error(format("compressed BTF (neural): neural.weights is %lld × %lld, the network "
                         "of its params needs 1 × %lld",
                         (long long)w.rows, (long long)w.cols,
                         (long long)nn::Net::paramCount(m_net.sizes)));
    for (float x : w.data)
      if (!std::isfinite(x)) throw Error("compressed BTF (neural): neural.weights holds a non-finite value");
    m_net.params = w.data;
    m_z = &m_c.array("neural.latents");
    if (m_z->rows != m_info.texels() || m_z->cols != m_shape.latent)
      throw Error(format("compressed BTF (neural): neural.latents is %lld × %lld, expected "
                         "%lld × %d",
                         (long long)m_z->rows, (long long)m_z->cols,
                         (long long)m_info.texels(), m_shape.latent));
    for (float x : m_z->data)
      if (!std::isfinite(x)) throw Error("compressed BTF (neural): neural.latents holds a non-finite value");
    m_gain = &m_c.array("neural.gain");
    if (m_gain->rows != m_info.texels() || m_gain->cols != 1)
      throw Error(format("compressed BTF (neural): neural.gain is %lld × %lld, expected %lld × 1",
                         (long long)m_gain->rows, (long long)m_gain->cols,
                         (long long)m_info.texels()));
    for (float x : m_gain->data)
      if (!(std::isfinite(x) && x >= 0))
        throw Error("compressed BTF (neural): neural.gain holds a negative or non-finite value");
    m_n = m_info.nDirs();
    for (int l = 0; l < m_n; ++l) m_cos.push_back(lightCosine(float((*m_dirs)[l].w.z)));
    m_terms = pairTerms(m_net, m_shape.latent,
                        pairFeatures(*m_dirs, m_shape.encoding, m_shape.minimalFrame));
  }
  std::string kind() const override { return "neural"; }
  bool continuous() const override { return true; }

  void texel(int64_t t, float* out) const override {
    check(t);
    const int64_t pairs = int64_t(m_n) * m_n, block = 1024;
    if (m_gain->data[size_t(t)] == 0) {
      std::fill_n(out, size_t(pairs) * 3, 0.f);
      return;
    }
    nn::Pass p;
    Mat a0;
    for (int64_t k0 = 0; k0 < pairs; k0 += block) {
      const int64_t n = std::min(block, pairs - k0);
      decodeBlock(m_net, m_shape.latent, m_z->row(t), m_terms.middleCols(k0, n), p, a0);
      const Mat& y = p.a.back();
      for (int64_t i = 0; i < n; ++i)
        emit(t, m_cos[size_t((k0 + i) % m_n)], y.col(i).data(), out + size_t(k0 + i) * 3);
    }
  }
  std::array<float, 3> value(int64_t t, int view, int light) const override {
    check(t);
    if (view < 0 || view >= m_n || light < 0 || light >= m_n)
      throw Error(format("direction pair (%d, %d) outside the set's %d directions", view, light, m_n));
    nn::Pass p;
    Mat a0;
    decodeBlock(m_net, m_shape.latent, m_z->row(t), m_terms.col(int64_t(view) * m_n + light), p, a0);
    std::array<float, 3> rgb{};
    emit(t, m_cos[size_t(light)], p.a.back().data(), rgb.data());
    return rgb;
  }
  // Continuous in direction: the network at the pair itself, no interpolation between the set's.
  std::array<float, 3> evaluate(int64_t t, double thetaI, double phiI, double thetaO,
                                double phiO) const override {
    check(t);
    const int D = featureCount(m_shape.encoding);
    float f[36];
    features(m_shape.encoding, sphericalDir(thetaI, phiI), sphericalDir(thetaO, phiO), f,
             m_shape.minimalFrame);
    const auto W = m_net.W(0);
    Mat terms = W.rightCols(D) * Eigen::Map<const Vec>(f, D) + m_net.b(0);
    nn::Pass p;
    Mat a0;
    decodeBlock(m_net, m_shape.latent, m_z->row(t), terms, p, a0);
    std::array<float, 3> rgb{};
    emit(t, lightCosine(f[2]), p.a.back().data(), rgb.data());
    return rgb;
  }

 private:
  void check(int64_t t) const {
    if (t < 0 || t >= m_info.texels())
      throw Error(format("texel %lld outside the BTF's %lld", (long long)t,
                         (long long)m_info.texels()));
  }
  void emit(int64_t t, float cosine, const float* y, float* rgb) const {
    const float g = m_gain->data[size_t(t)] * cosine;
    const float in[3] = {y[0] * g, y[1] * g, y[2] * g};
    fromColour(m_c.colour, in, rgb);  // ≥ 0, finite
  }
  CompressedBtf m_c;
  Shape m_shape;
  nn::Net m_net;
  const CArray *m_z = nullptr, *m_gain = nullptr;
  std::vector<float> m_cos;  // per light direction
  Mat m_terms;
  int m_n = 0;
};

}  // namespace

std::unique_ptr<Encoder> makeNeuralEncoder(const CodecSettings& s, const BtfInfo& i,
                                           const CancelToken* c) {
  return std::make_unique<NeuralEncoder>(s, i, c);
}
std::unique_ptr<Decoder> makeNeuralDecoder(CompressedBtf c) {
  return std::make_unique<NeuralDecoder>(std::move(c));
}

}  // namespace btf
