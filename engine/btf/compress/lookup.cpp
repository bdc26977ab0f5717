// Batched lookups, spatial slices and the tile average of a BTF behind the Decoder API
// (lookup.h): the one implementation `btfsim slice` and the Python package share.
#include <btf/compress/lookup.h>
#include <btf/core/error.h>
#include <btf/core/run_context.h>
#include <btf/directions/direction_set.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace btf {

namespace {

// Up to four set directions around a unit vector; 0 when it is at or below the horizon.
int weightsOf(const DirectionSet& dirs, const double* w, DirWeight out[4]) {
  if (!(std::isfinite(w[0]) && std::isfinite(w[1]) && std::isfinite(w[2]))) return 0;
  const double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  if (!(len > 0) || w[2] / len <= 0) return 0;
  const double z = std::min(1.0, w[2] / len);
  return dirs.interpolate(std::acos(z), std::atan2(w[1], w[0]), out);
}

int64_t wrap(int64_t i, int n) {
  const int64_t r = i % n;
  return r < 0 ? r + n : r;
}

}  // namespace

namespace {

// One lookup's direction pairs and texels: up to 16 (view, light) pairs of the set with their
// weights, and the four texels of the bilinear footprint with theirs. False when the lookup is 0
// (a direction at or below the horizon, or a position that is not finite).
struct Footprint {
  int pairs = 0;
  double pw[16];
  int pv[16], pl[16];
  int texels = 0;
  int64_t t[4];
  double tw[4];
  bool cached = false;  // pairs hold the weights of directions wi, wo
  double wi[3], wo[3];
};

bool footprint(const BtfInfo& I, const DirectionSet& dirs, const double* uv, const double* wi,
               const double* wo, Footprint& f) {
  const double u = uv[0], v = uv[1];
  if (!std::isfinite(u) || !std::isfinite(v)) return false;
  // The directions of the lookup before (a directional light and an orthographic camera over a
  // flat surface ask every pixel at the same pair): its pairs and weights again.
  if (!(f.cached && std::memcmp(wi, f.wi, sizeof f.wi) == 0 &&
        std::memcmp(wo, f.wo, sizeof f.wo) == 0)) {
    f.cached = false;
    DirWeight wl[4], wv[4];
    const int nl = weightsOf(dirs, wi, wl);
    const int nv = nl ? weightsOf(dirs, wo, wv) : 0;
    if (!nv) return false;
    f.pairs = 0;
    for (int a = 0; a < nv; ++a)
      for (int b = 0; b < nl; ++b) {
        const double ww = wv[a].weight * wl[b].weight;
        if (ww == 0) continue;
        f.pw[f.pairs] = ww, f.pv[f.pairs] = wv[a].index, f.pl[f.pairs++] = wl[b].index;
      }
    std::memcpy(f.wi, wi, sizeof f.wi);
    std::memcpy(f.wo, wo, sizeof f.wo);
    f.cached = true;
  }
  // As Decoder::evaluateAt: texel centres at integer + ½, bilinear over four texels.
  const double fx = (u - std::floor(u)) * I.nu - 0.5;
  const double fy = (v - std::floor(v)) * I.nv - 0.5;
  const double x0 = std::floor(fx), y0 = std::floor(fy);
  const double ax = fx - x0, ay = fy - y0;
  // Columns x0 and x0 + 1 and rows y0 and y0 + 1, wrapped (x0 ≥ −1: one compare each).
  int64_t cx[2] = {int64_t(x0), int64_t(x0) + 1}, cy[2] = {int64_t(y0), int64_t(y0) + 1};
  for (int k = 0; k < 2; ++k) {
    if (cx[k] < 0 || cx[k] >= I.nu) cx[k] = wrap(cx[k], I.nu);
    if (cy[k] < 0 || cy[k] >= I.nv) cy[k] = wrap(cy[k], I.nv);
  }
  f.texels = 0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const double w = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
      if (w == 0) continue;
      f.tw[f.texels] = w;
      f.t[f.texels++] = cx[i] + int64_t(I.nu) * cy[j];
    }
  return true;
}

// The n lookups, `one(k, footprint, out)` filling a lookup that is not 0.
template <class One>
void lookups(const BtfInfo& I, size_t n, const double* uv, const double* wi, const double* wo,
             float* out, const CancelToken* cancel, const One& one) {
  const DirectionSet dirs = DirectionSet::fromName(I.directionSet);
  if (dirs.size() != I.nDirs())
    throw Error("the direction set of the BTF does not match its header");
  parallelForChunks(
      int64_t(n), 4096,
      [&](int64_t k0, int64_t k1) {
        Footprint f;
        for (int64_t k = k0; k < k1; ++k) {
          float* o = out + size_t(k) * 3;
          o[0] = o[1] = o[2] = 0.f;
          if (footprint(I, dirs, uv + size_t(k) * 2, wi + size_t(k) * 3, wo + size_t(k) * 3, f))
            one(size_t(k), f, o);
        }
      },
      cancel);
  throwIfCancelled(cancel, "lookup");
}

// Each texel's value interpolated between the set's directions in double, rounded once to float
// (as Decoder::evaluateAt), then the texels blended in double.
template <class Texel>
void blend(const Footprint& f, const Texel& texel, float* o) {
  double acc[3] = {0, 0, 0};
  for (int q = 0; q < f.texels; ++q) {
    const auto tv = texel(f.t[q]);
    for (int c = 0; c < 3; ++c) acc[c] += f.tw[q] * tv[size_t(c)];
  }
  for (int c = 0; c < 3; ++c) o[c] = float(acc[c]);
}

std::array<float, 3> rounded(const double tv[3]) {
  return {float(tv[0]), float(tv[1]), float(tv[2])};
}

// A unit vector's (θ, φ) as the lookups read them (its z clamped to 1).
void angles(const double* w, double& theta, double& phi) {
  const double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  theta = std::acos(std::min(1.0, w[2] / len));
  phi = std::atan2(w[1], w[0]);
}

}  // namespace

void evaluateBatch(const Decoder& d, size_t n, const double* uv, const double* wi, const double* wo,
                   float* out, const CancelToken* cancel) {
  if (d.continuous()) {
    // The decoder's own value at the pair itself (the neural codec), as `btfsim render` reads it.
    lookups(d.info(), n, uv, wi, wo, out, cancel, [&](size_t k, const Footprint& f, float* o) {
      double ti, pi, to, po;
      angles(wi + k * 3, ti, pi);
      angles(wo + k * 3, to, po);
      blend(f, [&](int64_t t) { return d.evaluate(t, ti, pi, to, po); }, o);
    });
    return;
  }
  lookups(d.info(), n, uv, wi, wo, out, cancel, [&](size_t, const Footprint& f, float* o) {
    blend(
        f,
        [&](int64_t t) {
          double tv[3] = {0, 0, 0};
          for (int p = 0; p < f.pairs; ++p) {
            const auto x = d.value(t, f.pv[p], f.pl[p]);
            for (int c = 0; c < 3; ++c) tv[c] += f.pw[p] * x[size_t(c)];
          }
          return rounded(tv);
        },
        o);
  });
}

void evaluateBatch(const BtfInfo& info, const float* values, size_t n, const double* uv,
                   const double* wi, const double* wo, float* out, const CancelToken* cancel) {
  const size_t nd = size_t(info.nDirs()), stride = nd * nd * 3;
  const float* end = values + size_t(info.texels()) * stride;
  lookups(info, n, uv, wi, wo, out, cancel, [&](size_t, const Footprint& f, float* o) {
    // Every (texel, pair) term at once in float, four lanes a value (RGB and the next value's
    // first channel, ignored): up to 4 × 16 reads of 16 bytes, one multiply-add each.
    size_t off[16];
    for (int p = 0; p < f.pairs; ++p) off[p] = (size_t(f.pv[p]) * nd + size_t(f.pl[p])) * 3;
#if defined(__SSE2__)
    __m128 acc = _mm_setzero_ps();
    for (int q = 0; q < f.texels; ++q) {
      const float* base = values + size_t(f.t[q]) * stride;
      for (int p = 0; p < f.pairs; ++p) {
        const float* x = base + off[p];
        const __m128 w = _mm_set1_ps(float(f.tw[q] * f.pw[p]));
        // The store's last value has no fourth float after it: read it lane by lane.
        const __m128 v = x + 4 <= end ? _mm_loadu_ps(x) : _mm_setr_ps(x[0], x[1], x[2], 0.f);
        acc = _mm_add_ps(acc, _mm_mul_ps(w, v));
      }
    }
    alignas(16) float r[4];
    _mm_store_ps(r, acc);
    o[0] = r[0], o[1] = r[1], o[2] = r[2];
#else
    float a0 = 0, a1 = 0, a2 = 0;
    for (int q = 0; q < f.texels; ++q) {
      const float* base = values + size_t(f.t[q]) * stride;
      for (int p = 0; p < f.pairs; ++p) {
        const float* x = base + off[p];
        const float w = float(f.tw[q] * f.pw[p]);
        a0 += w * x[0], a1 += w * x[1], a2 += w * x[2];
      }
    }
    o[0] = a0, o[1] = a1, o[2] = a2;
    (void)end;
#endif
  });
}

std::vector<float> allValues(const Decoder& d, const CancelToken* cancel) {
  const BtfInfo& I = d.info();
  const size_t m = size_t(I.nDirs()) * size_t(I.nDirs()) * 3;
  std::vector<float> all(size_t(I.texels()) * m);
  parallelForChunks(
      I.texels(), 16,
      [&](int64_t t0, int64_t t1) {
        for (int64_t t = t0; t < t1; ++t) d.texel(t, all.data() + size_t(t) * m);
      },
      cancel);
  throwIfCancelled(cancel, "reading the values");
  return all;
}

std::vector<float> spatialSlice(const Decoder& d, double thetaV, double phiV, double thetaL,
                                double phiL, const CancelToken* cancel) {
  const BtfInfo& I = d.info();
  const DirectionSet dirs = DirectionSet::fromName(I.directionSet);
  if (dirs.size() != I.nDirs())
    throw Error("the direction set of the BTF does not match its header");
  std::vector<float> img(size_t(I.texels()) * 3, 0.f);
  if (d.continuous()) {
    // The decoder's own value at the pair itself (the neural codec), as `btfsim render` and
    // the batched lookups read it.
    parallelForChunks(
        I.texels(), 256,
        [&](int64_t t0, int64_t t1) {
          for (int64_t t = t0; t < t1; ++t) {
            const auto val = d.evaluate(t, thetaL, phiL, thetaV, phiV);
            std::copy(val.begin(), val.end(), img.begin() + t * 3);
          }
        },
        cancel);
    throwIfCancelled(cancel, "slice");
    return img;
  }
  const auto lw = dirs.interpolate(thetaL, phiL);
  const auto vw = dirs.interpolate(thetaV, phiV);
  parallelForChunks(
      I.texels(), 256,
      [&](int64_t t0, int64_t t1) {
        for (int64_t t = t0; t < t1; ++t)
          for (const auto& v : vw)
            for (const auto& l : lw) {
              const auto val = d.value(t, v.index, l.index);
              const float w = float(v.weight * l.weight);
              for (int k = 0; k < 3; ++k) img[size_t(t) * 3 + size_t(k)] += w * val[size_t(k)];
            }
      },
      cancel);
  throwIfCancelled(cancel, "slice");
  return img;
}

std::vector<float> tileAverage(const Decoder& d, const CancelToken* cancel) {
  const BtfInfo& I = d.info();
  const size_t m = size_t(I.nDirs()) * size_t(I.nDirs()) * 3;
  std::vector<double> sum(m, 0.0);
  std::vector<float> tex(m);
  for (int64_t t = 0; t < I.texels(); ++t) {
    if (t % 16 == 0) throwIfCancelled(cancel, "tile average");
    d.texel(t, tex.data());
    for (size_t k = 0; k < m; ++k) sum[k] += tex[k];
  }
  std::vector<float> out(m);
  for (size_t k = 0; k < m; ++k) out[k] = float(sum[k] / double(std::max<int64_t>(1, I.texels())));
  return out;
}

}  // namespace btf
