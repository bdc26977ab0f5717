// The reciprocal gather: the final gather's tile sums per (view, light) and the per-pair scale
// that makes them symmetric (reciprocal_gather.h).
#include <btf/core/error.h>
#include <btf/core/run_context.h>
#include <btf/sim/reciprocal_gather.h>
#include <btf/sim/shading.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace btf {

std::vector<double> gatherTileSums(const NetworkGather& gather, const HitMaps& maps,
                                   const TileGeometry& geom, const DirectionSet& dirs, Comm& comm,
                                   ProgressReporter* progress, const CancelToken* cancel,
                                   std::vector<uint8_t>* occlusion) {
  const int nD = dirs.size(), nL = gather.lighting().lights();
  BTF_CHECK(nL == nD && maps.directions() == nD);
  const SampleGrid& g = maps.grid();
  const int64_t su = g.su(), samples = g.samples();
  const float invK2 = 1.0f / float(g.spp * g.spp);
  const size_t row = size_t(nL) * 3;
  // This rank's views: a contiguous share.
  const int R = comm.size(), me = comm.rank();
  const int v0 = int(int64_t(nD) * me / R), v1 = int(int64_t(nD) * (me + 1) / R);
  std::vector<double> mine(size_t(v1 - v0) * row, 0.0);
  const size_t nP = gather.network().points().size(), nLk = gather.network().links().size();
  const int rays = gather.occlusionRays();
  if (occlusion && (rays == 0 || rays > 254)) occlusion = nullptr;  // nothing to keep / no room
  if (occlusion) occlusion->assign(size_t(nD) * size_t(samples), uint8_t(255));
  parallelForChunks(
      v1 - v0, 1,
      [&](int64_t b, int64_t e) {
        thread_local NetworkGather::Weights acc;
        for (int64_t k = b; k < e; ++k) {
          const int view = v0 + int(k);
          acc.reset(nP, nLk, nL);
          const DVec3 wv = dirs[view].w;
          for (int64_t si = 0; si < samples; ++si) {
            const uint32_t prim = maps.prim(view, si);
            if (prim == kNoHit) continue;
            const DVec3 p0 = g.position(int(si % su), int(si / su));
            const Vec3 p = Vec3(p0 + double(maps.depth(view, si)) * wv);
            Vec3 ng, ns;
            if (!hitNormals(geom, prim, maps.bu(view, si), maps.bv(view, si), Vec3(wv), &ng, &ns))
              continue;
            float alpha = -1;
            gather.addWeights(p, ng, ns, prim, Vec3(wv), invK2, acc, &alpha);
            if (occlusion && alpha >= 0)
              (*occlusion)[size_t(view) * size_t(samples) + size_t(si)] =
                  uint8_t(std::lround(alpha * float(rays)));
          }
          gather.sumWeights(acc, &mine[size_t(k) * row]);
          if (progress) progress->add(R);  // the ranks go at about the same pace
        }
      },
      cancel);
  throwIfCancelled(cancel, "reciprocal gather");
  if (R == 1) return mine;
  // Every rank's rows (and its views' occluded fractions) to every rank.
  std::string packed(reinterpret_cast<const char*>(mine.data()), mine.size() * sizeof(double));
  if (occlusion)
    packed.append(reinterpret_cast<const char*>(occlusion->data() + size_t(v0) * size_t(samples)),
                  size_t(v1 - v0) * size_t(samples));
  std::vector<double> all(size_t(nD) * row, 0.0);
  const std::vector<std::string> got = comm.allgather(packed);
  for (int q = 0; q < R; ++q) {
    const int a = int(int64_t(nD) * q / R), b = int(int64_t(nD) * (q + 1) / R);
    const std::string& s = got[size_t(q)];
    const size_t sums = size_t(b - a) * row * sizeof(double);
    if (s.size() != sums + (occlusion ? size_t(b - a) * size_t(samples) : 0))
      throw Error("reciprocal gather: rank " + std::to_string(q) + " sent a wrong-sized answer");
    std::memcpy(&all[size_t(a) * row], s.data(), sums);
    if (occlusion && q != me)
      std::memcpy(occlusion->data() + size_t(a) * size_t(samples), s.data() + sums,
                  size_t(b - a) * size_t(samples));
  }
  return all;
}

ReciprocalScale reciprocalScale(const std::vector<double>& I, int n) {
  BTF_CHECK(n >= 1 && I.size() == size_t(n) * size_t(n) * 3);
  ReciprocalScale r;
  r.scale.assign(I.size(), 1.0f);
  double top = 0;
  for (double x : I)
    if (std::isfinite(x)) top = std::max(top, x);
  const double tiny = 1e-6 * top;
  for (int v = 0; v < n; ++v)
    for (int l = 0; l < n; ++l)
      for (int c = 0; c < 3; ++c) {
        const double a = I[(size_t(v) * n + l) * 3 + c], b = I[(size_t(l) * n + v) * 3 + c];
        if (!(a > tiny) || !std::isfinite(b)) continue;  // nothing gathered: nothing to scale
        double s = 0.5 * (a + std::max(b, 0.0)) / a;
        if (s < 0.5 || s > 2.0) {
          s = std::clamp(s, 0.5, 2.0);
          ++r.clamped;
        }
        r.scale[(size_t(v) * n + l) * 3 + c] = float(s);
        r.maxCorrection = std::max(r.maxCorrection, std::abs(s - 1));
      }
  return r;
}

}  // namespace btf
