// Constructed BTFs for the compression tests (no simulation: known structure, exact values).
#pragma once
#include <btf/compress/codec.h>
#include <btf/core/math.h>
#include <btf/directions/direction_set.h>
#include <btf/store/btf_store.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace btf::test {

// A raw BTF whose texel t holds Σ_j a_tj f_j(view) g_j(light) · colour_t (rank ≤ 2 per channel,
// and the functions f_j, g_j are shared by all texels). zeroTexels are all zero; `range` scales
// texel t by range^(t / (T − 1)) (dynamic range).
inline BtfInfo syntheticInfo(int nu, int nv, const std::string& dirs) {
  BtfInfo info;
  info.nu = nu;
  info.nv = nv;
  info.directionSet = dirs;
  const DirectionSet set = DirectionSet::fromName(dirs);
  for (const auto& d : set.dirs())
    info.dirsDeg.push_back({d.theta * 180 / M_PI, d.phi * 180 / M_PI});
  info.chunkTexels = 7;
  info.hasVmf = false;
  info.sceneName = "synthetic";
  info.sceneHash = std::string(1, '0');  // (a string literal trips GCC 12 -Wrestrict)
  info.sceneJson = "{}";
  info.plan = "{}";
  return info;
}

inline std::vector<float> syntheticValues(const BtfInfo& info,
                                          const std::vector<int64_t>& zeroTexels,
                                          double range = 1) {
  const DirectionSet ds = DirectionSet::fromName(info.directionSet);
  const int n = info.nDirs();
  const int64_t T = info.texels();
  std::vector<float> v(size_t(T) * n * n * 3);
  for (int64_t t = 0; t < T; ++t) {
    if (std::find(zeroTexels.begin(), zeroTexels.end(), t) != zeroTexels.end()) continue;
    const double a0 = 0.5 + 0.4 * std::sin(double(t)), a1 = 0.3 + 0.25 * std::cos(1.7 * double(t));
    const double col[3] = {0.8, 0.5 + 0.1 * (t % 3), 0.3};
    const double s = T > 1 ? std::pow(range, double(t) / double(T - 1)) : 1.0;
    for (int o = 0; o < n; ++o)
      for (int l = 0; l < n; ++l) {
        const double co = ds[o].w.z, cl = ds[l].w.z;
        const double f0 = 1.0 / M_PI, g0 = 1.0;  // Lambert-like
        // A lobe around a fixed direction (separable: each texel has rank 2).
        const double f1 = std::pow(std::max(0.0, 0.6 * ds[o].w.x + 0.8 * co), 4), g1 = cl;
        const double val = s * (a0 * f0 * g0 + a1 * f1 * g1);
        for (int c = 0; c < 3; ++c) v[((size_t(t) * n + o) * n + l) * 3 + c] = float(val * col[c]);
      }
  }
  return v;
}

inline std::string writeRaw(const std::string& path, const BtfInfo& info,
                            const std::vector<float>& v) {
  BtfWriter w(path, info, false);
  w.writeVmf({});
  const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
  for (int c = 0; c < info.chunks(); ++c)
    w.writeChunk(c, v.data() + size_t(info.chunkBegin(c)) * stride);
  w.finish();
  return path;
}

/// An encoder of settings `s`, trained on its training texels taken from `values` (texel-major).
inline std::unique_ptr<Encoder> trainedEncoder(const CodecSettings& s, const BtfInfo& info,
                                               const std::vector<float>& values) {
  auto enc = makeEncoder(s, info);
  const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
  const auto train = enc->trainingTexels();
  if (!train.empty()) {
    std::vector<float> tv;
    for (int64_t t : train)
      tv.insert(tv.end(), values.begin() + long(size_t(t) * stride),
                values.begin() + long(size_t(t + 1) * stride));
    enc->train(tv.data());
  }
  return enc;
}

}  // namespace btf::test
