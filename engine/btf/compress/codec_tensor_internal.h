// The clustered tensor codec (thesis §4.4.2; docs/compression.md "tensor"): texels are
// clustered by IRP k-means on sign sketches of their whole aBRDF; per cluster and colour
// channel, the views × lights × texels tensor is factorised as a Tucker model — view and light
// bases from HOSVD refined by HOOI sweeps on the training texels, then every texel projected on
// them as it streams in, and at the end a texel-mode basis ("core") per cluster from all of its
// texels. Ranks per (cluster, channel, mode) are chosen greedily by energy per byte toward
// the ratio or error target.
//
// Arrays (K clusters, n directions; flat arrays are N × 1, row-major inside each block):
//   cluster            texels × 1 (f16 when K ≤ 2048: exact integers), the texel's cluster
//   c{c}.ranks         K × 3 f32: Rv, Rl, Rt of cluster k (0 = the channel is zero there)
//   c{c}.view          Σ_k n·Rv_k: cluster k's block at Σ_{j<k} n·Rv_j, element v·Rv + a
//   c{c}.light         Σ_k n·Rl_k: likewise, element l·Rl + b
//   c{c}.core          Σ_k Rt·Rv·Rl: element (j·Rv + a)·Rl + b (texel factor j)
//   coef               Σ_t Σ_c Rt_{k(t),c}: texel t's coefficients in texel order, channel 0's
//                      Rt first; a texel's offset is the sum over earlier texels (decoders derive
//                      it from the cluster array)
//   value_c(t, v, l) = Σ_j coef_t[j] Σ_a Σ_b view[v, a] core[j, a, b] light[l, b]
//
// This header (internal to engine/btf/compress) holds what the encoder
// (codec_tensor_encoder.cpp: clustering, HOOI, rank choice, the file's arrays) and the decoder
// (codec_tensor_decoder.cpp: values, levels, the GLSL decoder's tables) share.
#pragma once
#include <btf/compress/halfway.h>
#include <btf/compress/mip.h>
#include <btf/core/error.h>
#include <btf/core/format.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <nlohmann/json.hpp>

#include "codec.h"
#include "tensor.h"

namespace btf {
namespace tensordetail {

constexpr int kMaxRv = 128, kMaxRl = 128, kMaxRt = 32;  // the GLSL decoder's arrays
constexpr int kSketchDim = 64;
constexpr int kHooiSweeps = 2;
// Memory the encoder may hold (docs/compression.md): training values (and train()'s copy of
// them), and every texel's projections.
constexpr uint64_t kTrainingBytes = uint64_t(1) << 30, kProjectionBytes = uint64_t(1) << 30;

// The stored blocks are row-major (v·Rv + a, a·Rl + b).
using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Ranks {
  int v = 0, l = 0, t = 0;
};

inline double tail(const la::VecD& e, int r) {
  double s = 0;
  for (int64_t i = r; i < e.size(); ++i) s += e[i];
  return s;
}
inline double at(const la::VecD& e, int r) {
  return r < e.size() ? e[r] : 0.0;
}
inline float roundStored(float x, bool half) {
  return half ? la::halfToFloat(la::floatToHalf(x)) : x;
}

}  // namespace tensordetail
}  // namespace btf
