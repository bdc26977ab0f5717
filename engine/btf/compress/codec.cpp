#include "codec.h"

#include <btf/compress/mip.h>
#include <btf/core/error.h>
#include <btf/core/format.h>
#include <btf/core/math.h>
#include <btf/core/rng.h>
#include <btf/directions/direction_set.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <nlohmann/json.hpp>

namespace btf {

const std::vector<std::string>& codecNames() {
  static const std::vector<std::string> names = {"nmf", "svd", "perview", "lpca", "tensor",
                                                  "neural"};
  return names;
}

void validate(const CodecSettings& s) {
  const auto& n = codecNames();
  if (std::find(n.begin(), n.end(), s.codec) == n.end())
    throw Error("--codec: unknown codec '" + s.codec +
                "' (expected nmf, svd, perview, lpca, tensor or neural)");
  if (s.colour != "rgb" && s.colour != "ycc")
    throw Error("--colour-model: '" + s.colour + "' (expected rgb or ycc)");
  if (s.components < 0) throw Error("--components: must be ≥ 0");
  if (!(s.targetRmse >= 0 && s.targetRmse < 1))
    throw Error("--target-rmse: must be a relative RMSE in [0, 1), e.g. 0.05");
  if (!(s.targetRatio >= 0)) throw Error("--target-ratio: must be ≥ 0");
  if (s.targetRmse > 0 && s.targetRatio > 0)
    throw Error("--target-rmse and --target-ratio: give one of them, not both");
  if (!(s.beta > 0 && s.beta <= 1)) throw Error("--beta: must be in (0, 1]");
  if (s.maxRank < 1 || s.maxRank > 64) throw Error("--max-rank: must be in [1, 64]");
  if (s.nmfIterations < 1) throw Error("--nmf-iterations: must be ≥ 1");
  if (s.trainTexels < 1) throw Error("--train-texels: must be ≥ 1");
  if (s.clusters < 0) throw Error("--clusters: must be ≥ 0 (0 = the codec's default)");
  if (s.codec == "neural") {
    if (s.components > 64)
      throw Error("--components: the neural codec's latent holds at most 64 values per texel");
    if (s.neuralHidden < 4 || s.neuralHidden > 256) throw Error("--hidden: must be in [4, 256]");
    if (s.neuralLayers < 1 || s.neuralLayers > 8) throw Error("--hidden-layers: must be in [1, 8]");
    if (s.neuralSteps < 1) throw Error("--neural-steps: must be ≥ 1");
    if (!(s.neuralRate > 0 && s.neuralRate < 1)) throw Error("--learning-rate: must be in (0, 1)");
    if (s.neuralEncoding != "halfdiff" && s.neuralEncoding != "raw" &&
        s.neuralEncoding != "fourier")
      throw Error("--encoding: '" + s.neuralEncoding + "' (expected halfdiff, fourier or raw)");
  }
  if (s.halfway && s.codec != "tensor")
    throw Error("--halfway: the half-vector reparameterisation is an option of the tensor codec "
                "(not " + s.codec + ")");
}

std::string settingsJson(const CodecSettings& s) {
  nlohmann::ordered_json j;
  j["codec"] = s.codec;
  j["colour"] = s.colour;
  j["components"] = s.components;
  j["target_rmse"] = s.targetRmse;
  j["target_ratio"] = s.targetRatio;
  if (s.codec == "nmf") {
    j["beta"] = s.beta;
    j["beta_mode"] = la::betaModeName(s.betaMode);
    j["solver"] = la::nmfSolverName(s.solver);
    j["max_rank"] = s.maxRank;
    j["nmf_iterations"] = s.nmfIterations;
    j["nmf_tolerance"] = s.nmfTolerance;
  } else {
    j["train_texels"] = s.trainTexels;
    if (s.codec == "lpca") j["clusters"] = s.clusters > 0 ? s.clusters : 8;
    if (s.codec == "tensor") {
      j["clusters"] = s.clusters;  // 0: √(texels / 2), see clusters_used
      if (s.halfway) j["halfway"] = true;
    }
    if (s.codec == "neural") {
      j["neural_steps"] = s.neuralSteps;
      j["learning_rate"] = s.neuralRate;
    }
  }
  j["precision"] = s.half ? "f16" : "f32";
  j["seed"] = s.seed;
  return j.dump();
}

std::string channelArray(int channel, const char* what) {
  std::string s = "c";
  s += char('0' + channel);
  s += '.';
  s += what;
  return s;
}

int colourChannels(const std::string&) {
  return 3;
}
bool channelNonNegative(const std::string& colour, int c) {
  return colour == "rgb" || c == 0;
}

void toColour(const std::string& colour, const float rgb[3], float out[3]) {
  if (colour == "rgb") {
    out[0] = rgb[0], out[1] = rgb[1], out[2] = rgb[2];
    return;
  }
  const float y = (rgb[0] + rgb[1] + rgb[2]) * (1.f / 3.f);
  out[0] = y;
  out[1] = rgb[0] - y;
  out[2] = rgb[2] - y;
}

void fromColour(const std::string& colour, const float in[3], float rgb[3]) {
  if (colour == "rgb") {
    rgb[0] = in[0], rgb[1] = in[1], rgb[2] = in[2];
  } else {
    rgb[0] = in[0] + in[1];
    rgb[2] = in[0] + in[2];
    rgb[1] = in[0] - in[1] - in[2];
  }
  for (int c = 0; c < 3; ++c) rgb[c] = std::isfinite(rgb[c]) ? std::max(0.f, rgb[c]) : 0.f;
}

std::vector<int64_t> stratifiedTexels(int nu, int nv, int n, uint64_t seed) {
  const int64_t total = int64_t(nu) * nv;
  std::vector<int64_t> out;
  if (n >= total) {
    for (int64_t t = 0; t < total; ++t) out.push_back(t);
    return out;
  }
  // A gx × gy grid of cells with gx·gy ≥ n, aspect following the texel grid; one jittered texel
  // per cell, then a deterministic thinning to exactly n.
  const double aspect = double(nu) / nv;
  int gx = std::max(1, int(std::ceil(std::sqrt(n * aspect))));
  int gy = std::max(1, (n + gx - 1) / gx);
  gx = std::min(gx, nu);
  gy = std::min(gy, nv);
  while (int64_t(gx) * gy < n) {
    if (gx < nu) ++gx;
    if (int64_t(gx) * gy < n && gy < nv) ++gy;
  }
  std::vector<int64_t> cand;
  for (int cy = 0; cy < gy; ++cy)
    for (int cx = 0; cx < gx; ++cx) {
      const int u0 = int(int64_t(cx) * nu / gx), u1 = int(int64_t(cx + 1) * nu / gx);
      const int v0 = int(int64_t(cy) * nv / gy), v1 = int(int64_t(cy + 1) * nv / gy);
      const uint64_t h = hashKeys(seed, uint64_t(cx), uint64_t(cy), 7);
      const int u = u0 + int(h % uint64_t(std::max(1, u1 - u0)));
      const int v = v0 + int((h >> 32) % uint64_t(std::max(1, v1 - v0)));
      cand.push_back(int64_t(u) + int64_t(nu) * v);
    }
  // Keep n of them spread evenly over the candidate order.
  for (int i = 0; i < n; ++i) out.push_back(cand[size_t(int64_t(i) * int64_t(cand.size()) / n)]);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::unique_ptr<Encoder> makeEncoder(const CodecSettings& s, const BtfInfo& info,
                                     const CancelToken* cancel) {
  validate(s);
  if (s.codec == "nmf") return makeNmfEncoder(s, info, cancel);
  if (s.codec == "svd") return makeSvdEncoder(s, info, cancel);
  if (s.codec == "perview") return makePerViewEncoder(s, info, cancel);
  if (s.codec == "tensor") return makeTensorEncoder(s, info, cancel);
  if (s.codec == "neural") return makeNeuralEncoder(s, info, cancel);
  return makeLpcaEncoder(s, info, cancel);
}

std::unique_ptr<Decoder> makeDecoder(CompressedBtf c) {
  if (!c.levels.empty()) return makePyramidDecoder(std::move(c), 0);
  // The decoders check their arrays' shapes against the header; their errors name the file.
  const std::string where = c.source.empty() ? std::string("compressed BTF") : c.source;
  try {
    if (c.codec == "nmf") return makeNmfDecoder(std::move(c));
    if (c.codec == "svd") return makeSvdDecoder(std::move(c));
    if (c.codec == "perview") return makePerViewDecoder(std::move(c));
    if (c.codec == "lpca") return makeLpcaDecoder(std::move(c));
    if (c.codec == "tensor") return makeTensorDecoder(std::move(c));
    if (c.codec == "neural") return makeNeuralDecoder(std::move(c));
  } catch (const Error& e) {
    throw Error(where + ": " + e.what());
  }
  throw Error(where + ": unknown codec '" + c.codec +
              "' (expected nmf, svd, perview, lpca, tensor or neural)");
}

// ------------------------------------------------------------------ Decoder

Decoder::Decoder(BtfInfo info) : m_info(std::move(info)) {
  m_dirs = std::make_shared<DirectionSet>(DirectionSet::fromName(m_info.directionSet));
  if (m_dirs->size() != m_info.nDirs())
    throw Error("BTF direction set '" + m_info.directionSet + "' does not match its " +
                std::to_string(m_info.nDirs()) + " directions");
}

std::array<float, 3> Decoder::evaluate(int64_t t, double thetaI, double phiI, double thetaO,
                                       double phiO) const {
  const auto wl = m_dirs->interpolate(thetaI, phiI);
  const auto wv = m_dirs->interpolate(thetaO, phiO);
  std::array<double, 3> acc{0, 0, 0};
  for (const auto& a : wv)
    for (const auto& b : wl) {
      const double w = a.weight * b.weight;
      if (w == 0) continue;
      const auto v = value(t, a.index, b.index);
      for (int c = 0; c < 3; ++c) acc[size_t(c)] += w * v[size_t(c)];
    }
  return {float(acc[0]), float(acc[1]), float(acc[2])};
}

std::array<float, 3> Decoder::evaluateAt(double x, double y, double thetaI, double phiI,
                                         double thetaO, double phiO) const {
  // Texel centres at integer + ½.
  const double fx = x - 0.5, fy = y - 0.5;
  const double x0 = std::floor(fx), y0 = std::floor(fy);
  const double ax = fx - x0, ay = fy - y0;
  std::array<double, 3> acc{0, 0, 0};
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const double w = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
      if (w == 0) continue;
      const int64_t u = ((int64_t(x0) + i) % m_info.nu + m_info.nu) % m_info.nu;
      const int64_t v = ((int64_t(y0) + j) % m_info.nv + m_info.nv) % m_info.nv;
      const auto val = evaluate(u + int64_t(m_info.nu) * v, thetaI, phiI, thetaO, phiO);
      for (int c = 0; c < 3; ++c) acc[size_t(c)] += w * val[size_t(c)];
    }
  return {float(acc[0]), float(acc[1]), float(acc[2])};
}

namespace {

class ResampledDecoder final : public Decoder {
 public:
  ResampledDecoder(std::shared_ptr<const Decoder> d, const BtfInfo& target)
      : Decoder(withDirections(d->info(), target)), m_d(std::move(d)) {
    for (const auto& a : m_info.dirsDeg) m_rad.push_back({deg2rad(a[0]), deg2rad(a[1])});
  }
  void texel(int64_t t, float* out) const override {
    const int n = m_info.nDirs();
    for (int v = 0; v < n; ++v)
      for (int l = 0; l < n; ++l) {
        const auto x = value(t, v, l);
        std::copy(x.begin(), x.end(), out + (size_t(v) * size_t(n) + size_t(l)) * 3);
      }
  }
  std::array<float, 3> value(int64_t t, int view, int light) const override {
    const auto& o = m_rad[size_t(view)];
    const auto& i = m_rad[size_t(light)];
    return m_d->evaluate(t, i[0], i[1], o[0], o[1]);
  }
  std::array<float, 3> evaluate(int64_t t, double thetaI, double phiI, double thetaO,
                                double phiO) const override {
    return m_d->evaluate(t, thetaI, phiI, thetaO, phiO);
  }
  bool continuous() const override { return m_d->continuous(); }
  std::string kind() const override { return m_d->kind(); }

 private:
  static BtfInfo withDirections(BtfInfo i, const BtfInfo& target) {
    if (i.nu != target.nu || i.nv != target.nv)
      throw Error(format("texel grids differ (%d×%d vs %d×%d)", i.nu, i.nv, target.nu, target.nv));
    i.directionSet = target.directionSet;
    i.dirsDeg = target.dirsDeg;
    return i;
  }
  std::shared_ptr<const Decoder> m_d;
  std::vector<std::array<double, 2>> m_rad;
};

class RawDecoder final : public Decoder {
 public:
  explicit RawDecoder(std::unique_ptr<BtfReader> r)
      : Decoder(r->info()),
        m_r(std::move(r)),
        m_verified(new std::atomic<bool>[size_t(m_info.chunks())]) {
    for (int c = 0; c < m_info.chunks(); ++c) m_verified[size_t(c)] = false;
  }
  void texel(int64_t t, float* out) const override {
    verified(t);
    m_r->readTexelInto(t, out);
    const size_t n = size_t(m_info.nDirs()) * m_info.nDirs() * 3;
    for (size_t i = 0; i < n; ++i) out[i] = std::isfinite(out[i]) ? std::max(0.f, out[i]) : 0.f;
  }
  std::array<float, 3> value(int64_t t, int view, int light) const override {
    std::array<float, 3> v{};
    verified(t);
    m_r->readValue(t, view, light, v.data());
    // The decoder's contract (finite, >= 0) also for a crafted store whose chunk checksums hold.
    for (float& x : v) x = std::isfinite(x) ? std::max(0.f, x) : 0.f;
    return v;
  }
  std::string kind() const override { return "raw"; }

 private:
  // Every chunk a reader touches is checked once, the first time (readers never return values
  // from a damaged chunk: they fail naming it). Two threads may both verify a chunk; harmless.
  void verified(int64_t t) const {
    if (t < 0 || t >= m_info.texels()) return;  // the reader's own range error follows
    const size_t c = size_t(t / m_info.chunkTexels);
    if (m_verified[c].load(std::memory_order_acquire)) return;
    m_r->verifyChunk(int(c));
    m_verified[c].store(true, std::memory_order_release);
  }
  std::unique_ptr<BtfReader> m_r;
  std::unique_ptr<std::atomic<bool>[]> m_verified;
};

}  // namespace

std::unique_ptr<Decoder> openBtf(const std::string& path) {
  if (isCompressedFile(path)) return makeDecoder(readCompressed(path));
  return std::make_unique<RawDecoder>(std::make_unique<BtfReader>(path));
}

std::unique_ptr<Decoder> atDirections(std::shared_ptr<const Decoder> d, const BtfInfo& target) {
  return std::make_unique<ResampledDecoder>(std::move(d), target);
}

}  // namespace btf
