// Batched lookups, spatial slices and the tile average of a BTF behind the Decoder API
// (lookup.h): the one implementation `btfsim slice` and the Python package share.
#include <btf/compress/lookup.h>
#include <btf/core/error.h>
#include <btf/core/run_context.h>
#include <btf/directions/direction_set.h>

#include <algorithm>
#include <array>
#include <cmath>

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

// The lookups over any source of values: value(t, view, light) → three floats. The (view, light)
// pairs and their weights once per lookup, then each of the four texels a run of reads.
template <class Value>
void lookups(const BtfInfo& I, size_t n, const double* uv, const double* wi, const double* wo,
             float* out, const CancelToken* cancel, const Value& value) {
  const DirectionSet dirs = DirectionSet::fromName(I.directionSet);
  if (dirs.size() != I.nDirs())
    throw Error("the direction set of the BTF does not match its header");
  parallelForChunks(
      int64_t(n), 4096,
      [&](int64_t k0, int64_t k1) {
        for (int64_t k = k0; k < k1; ++k) {
          float* o = out + size_t(k) * 3;
          o[0] = o[1] = o[2] = 0.f;
          DirWeight wl[4], wv[4];
          const int nl = weightsOf(dirs, wi + size_t(k) * 3, wl);
          const int nv = nl ? weightsOf(dirs, wo + size_t(k) * 3, wv) : 0;
          const double u = uv[size_t(k) * 2], v = uv[size_t(k) * 2 + 1];
          if (!nv || !std::isfinite(u) || !std::isfinite(v)) continue;
          double pw[16];
          int pv[16], pl[16];
          int np = 0;
          for (int a = 0; a < nv; ++a)
            for (int b = 0; b < nl; ++b) {
              const double ww = wv[a].weight * wl[b].weight;
              if (ww == 0) continue;
              pw[np] = ww, pv[np] = wv[a].index, pl[np++] = wl[b].index;
            }
          // As Decoder::evaluateAt: texel centres at integer + ½, bilinear over four texels, each
          // texel's value interpolated between the set's directions in double, rounded once.
          const double fx = (u - std::floor(u)) * I.nu - 0.5;
          const double fy = (v - std::floor(v)) * I.nv - 0.5;
          const double x0 = std::floor(fx), y0 = std::floor(fy);
          const double ax = fx - x0, ay = fy - y0;
          double acc[3] = {0, 0, 0};
          for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i) {
              const double w = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
              if (w == 0) continue;
              const int64_t t =
                  wrap(int64_t(x0) + i, I.nu) + int64_t(I.nu) * wrap(int64_t(y0) + j, I.nv);
              double tv[3] = {0, 0, 0};
              for (int p = 0; p < np; ++p) {
                const auto x = value(t, pv[p], pl[p]);
                for (int c = 0; c < 3; ++c) tv[c] += pw[p] * x[size_t(c)];
              }
              for (int c = 0; c < 3; ++c) acc[c] += w * float(tv[c]);
            }
          for (int c = 0; c < 3; ++c) o[c] = float(acc[c]);
        }
      },
      cancel);
  throwIfCancelled(cancel, "lookup");
}

}  // namespace

void evaluateBatch(const Decoder& d, size_t n, const double* uv, const double* wi, const double* wo,
                   float* out, const CancelToken* cancel) {
  lookups(d.info(), n, uv, wi, wo, out, cancel,
          [&](int64_t t, int view, int light) { return d.value(t, view, light); });
}

void evaluateBatch(const BtfInfo& info, const float* values, size_t n, const double* uv,
                   const double* wi, const double* wo, float* out, const CancelToken* cancel) {
  const size_t nd = size_t(info.nDirs());
  lookups(info, n, uv, wi, wo, out, cancel, [&](int64_t t, int view, int light) {
    return values + ((size_t(t) * nd + size_t(view)) * nd + size_t(light)) * 3;
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
  const auto lw = dirs.interpolate(thetaL, phiL);
  const auto vw = dirs.interpolate(thetaV, phiV);
  std::vector<float> img(size_t(I.texels()) * 3, 0.f);
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
