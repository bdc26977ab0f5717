// What the simulator's rooms share (internal to engine/btf/sim): the clock, and the texel
// kernel that evaluates one (texel, view) row of lights — direct, the network's final gather or
// the path tracer — for the run, the estimate's calibration and the preview alike.
#pragma once
#include <btf/core/error.h>
#include <btf/core/hash.h>
#include <btf/core/run_context.h>
#include <btf/core/sysinfo.h>
#include <btf/geometry/tile_builder.h>
#include <btf/sim/path_tracer.h>
#include <btf/sim/reciprocal_gather.h>
#include <btf/sim/shading.h>
#include <btf/sim/simulator.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <future>
#include <nlohmann/json.hpp>

namespace btf {
namespace simdetail {

using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

inline bool anyGlossy(const std::vector<Material>& mats) {
  for (const Material& m : mats)
    if (m.type != BrdfType::Lambert && (m.ks.x > 0 || m.ks.y > 0 || m.ks.z > 0)) return true;
  return false;
}

// Everything that evaluates one (texel, view) row of lights: the direct kernel, the network's
// final gather, or the path tracer.
struct TexelKernel {
  const PeriodicTracer& tracer;
  const std::vector<Material>& materials;
  const DirectionSet& dirs;
  const HitMaps& maps;
  const DirectIllumination& direct;
  const NetworkGather* gather = nullptr;
  bool pathTrace = false;
  const AdaptiveTexelSampler* adaptive = nullptr;
  PathSettings pt;
  int ptPaths = 1;
  std::vector<DVec3> lights;
  /// Exact direct light by area for the flat faces (prepared); `direct` then skips them.
  const ExactDirect* exact = nullptr;

  /// Texels evaluated together per (block, view) item: the plain direct kernel lights a block
  /// light by light (DirectIllumination::evalTexelsView); the other kernels go texel by texel.
  int blockTexels() const { return adaptive || pathTrace ? 1 : DirectIllumination::kBlockTexels; }

  /// Texels t0 … t0 + count − 1 (row-major over nu columns) seen from `view`: texel k's row of
  /// lights at out + k · stride. Every value equals eval's.
  int64_t evalBlock(int64_t t0, int count, int nu, int view, float* out, size_t stride) const {
    BTF_CHECK(count >= 1 && count <= blockTexels());
    if (count == 1) {
      int64_t n = 0;
      for (int k = 0; k < count; ++k)
        n += eval(int((t0 + k) % nu), int((t0 + k) / nu), view, out + size_t(k) * stride);
      return n;
    }
    // count ≤ kBlockTexels: one block.
    int ti[DirectIllumination::kBlockTexels], tj[DirectIllumination::kBlockTexels];
    float* rows[DirectIllumination::kBlockTexels];
    for (int k = 0; k < count; ++k) {
      ti[k] = int((t0 + k) % nu), tj[k] = int((t0 + k) / nu);
      rows[k] = out + size_t(k) * stride;
    }
    const int64_t n = direct.evalTexelsView(ti, tj, count, view, rows);
    if (gather)
      for (int k = 0; k < count; ++k) addGather(ti[k], tj[k], view, rows[k]);
    return n;
  }

  int64_t eval(int i, int j, int view, float* out) const {
    const int nL = dirs.size();
    const SampleGrid& g = maps.grid();
    const int K2 = g.spp * g.spp;
    if (adaptive && !pathTrace) return adaptive->eval(i, j, view, out);
    if (pathTrace) {
      std::vector<Rgb> acc(size_t(nL), Rgb(0));
      const float w = 1.0f / (float(K2) * float(ptPaths));
      for (int s = 0; s < K2; ++s) {
        const int64_t si = g.sampleIndex(i, j, s);
        const DVec3 p0 = g.position(int(si % g.su()), int(si / g.su()));
        for (int q = 0; q < ptPaths; ++q) {
          Rng rng(hashKeys(pt.seed ^ 0x7e11, uint64_t(si), uint64_t(view), uint64_t(q)));
          tracePath(tracer, materials, p0, dirs[view].w, lights.data(), nL, pt, rng, w, acc.data());
        }
      }
      for (int l = 0; l < nL; ++l)
        for (int c = 0; c < 3; ++c) out[3 * l + c] = std::isfinite(acc[l][c]) ? acc[l][c] : 0.f;
      return int64_t(K2) * ptPaths * nL;
    }
    if (exact) {
      // One texel of the exact view (the run goes view by view over whole chunks instead).
      const int64_t t = int64_t(j) * g.nu + i;
      exact->evalView(view, t, t + 1, out, 0);  // overwrites the row
      return addBesideExact(i, j, view, out);
    }
    const int64_t n = direct.evalTexelView(i, j, view, out);
    if (gather) addGather(i, j, view, out);
    return n;
  }

  /// Views [v0, v1) of texels [t0, t1) with exact visibility: per view, every texel and light
  /// at once (texel t's view v at out + (t − t0)·texelStride + (v − v0)·nL·3), plus the smooth
  /// faces' samples and the gather. Returns the sampled kernel's BRDF evaluations.
  int64_t evalExactView(int64_t t0, int64_t t1, int view, int v0, float* out,
                        size_t texelStride) const {
    const int nL = dirs.size();
    const int nu = maps.grid().nu;
    float* base = out + size_t(view - v0) * size_t(nL) * 3;
    exact->evalView(view, t0, t1, base, texelStride);
    int64_t n = 0;
    if (exact->allShaded() && !gather) return n;
    for (int64_t t = t0; t < t1; ++t)
      n += addBesideExact(int(t % nu), int(t / nu), view, base + size_t(t - t0) * texelStride);
    return n;
  }

  /// n scattered texels seen from `view` (texel texels[k]'s row of lights at rows[k]), with
  /// exact visibility prepared once for all of them: every value equals eval's.
  int64_t evalExactTexels(const int64_t* texels, size_t n, int view, float* const* rows) const {
    exact->evalViewTexels(view, texels, n, rows);
    int64_t count = 0;
    if (exact->allShaded() && !gather) return count;
    const int nu = maps.grid().nu;
    for (size_t k = 0; k < n; ++k)
      count += addBesideExact(int(texels[k] % nu), int(texels[k] / nu), view, rows[k]);
    return count;
  }

  /// What the exact view leaves to texel (i, j)'s row: the smooth faces' sampled direct light
  /// and the gather, added to `out`. Returns the sampled kernel's BRDF evaluations.
  int64_t addBesideExact(int i, int j, int view, float* out) const {
    int64_t n = 0;
    if (!exact->allShaded()) {
      thread_local std::vector<float> row;
      row.resize(size_t(dirs.size()) * 3);
      n = direct.evalTexelView(i, j, view, row.data());
      for (size_t k = 0; k < row.size(); ++k) out[k] += row[k];
    }
    if (gather) addGather(i, j, view, out);
    return n;
  }

  // The network's final gather at texel (i, j)'s samples, added to its row.
  void addGather(int i, int j, int view, float* out) const {
    const SampleGrid& g = maps.grid();
    const int K2 = g.spp * g.spp;
    const DVec3 wv = dirs[view].w;
    const float invK2 = 1.0f / float(K2);
    const TileGeometry& geom = tracer.geometry();
    // With the reciprocal scale the texel's gathered row is summed apart, then scaled per light.
    thread_local std::vector<float> own;
    float* acc = out;
    if (gather->scaled()) {
      own.assign(size_t(dirs.size()) * 3, 0.f);
      acc = own.data();
    }
    for (int s = 0; s < K2; ++s) {
      const int64_t si = g.sampleIndex(i, j, s);
      const uint32_t prim = maps.prim(view, si);
      if (prim == kNoHit) continue;
      const DVec3 p0 = g.position(int(si % g.su()), int(si / g.su()));
      const Vec3 p = Vec3(p0 + double(maps.depth(view, si)) * wv);
      Vec3 ng, ns;
      if (!hitNormals(geom, prim, maps.bu(view, si), maps.bv(view, si), Vec3(wv), &ng, &ns))
        continue;
      gather->add(p, ng, ns, prim, Vec3(wv), invK2, acc, gather->cachedOcclusion(view, si));
    }
    if (acc != out) gather->addScaled(view, acc, out);
  }
};

}  // namespace simdetail
}  // namespace btf
