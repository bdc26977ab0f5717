#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/sim/hit_maps.h>

#include <cmath>

namespace btf {

DVec3 SampleGrid::position(int a, int b) const {
  double ja = 0.5, jb = 0.5;
  if (spp > 1) {
    const uint64_t h = hashKeys(seed, uint64_t(a), uint64_t(b), 0x5a17);
    ja = uniformFloat(h);
    jb = uniformFloat(mix64(h));
  }
  return {(a + ja) * Lx / su(), (b + jb) * Ly / sv(), 0.0};
}

RayHit traceSampleRay(const PeriodicTracer& tracer, const DVec3& p0, const DVec3& w, float* depth) {
  const TileGeometry& g = tracer.geometry();
  const double cosT = w.z;
  BTF_CHECK(cosT > 0);
  // Start just above the geometry's slab on the line through p0 along ω, travel along −ω.
  const double top = (std::max(double(g.zmax), 0.0) + 2 * tracer.epsilon()) / cosT;
  const DVec3 o = p0 + top * w;
  RayHit h = tracer.intersect(o, -w, 0.0);
  *depth = h.hit() ? float(top - h.t) : -INFINITY;
  return h;
}

void HitMaps::build(const PeriodicTracer& tracer, const DirectionSet& dirs, const SampleGrid& grid,
                    ProgressReporter* progress, const CancelToken* cancel) {
  m_grid = grid;
  m_nDirs = dirs.size();
  const size_t n = size_t(m_nDirs) * size_t(grid.samples());
  m_prim.assign(n, kNoHit);
  m_depth.assign(n, -INFINITY);
  m_u.assign(n, 0.f);
  m_v.assign(n, 0.f);
  const int su = grid.su(), sv = grid.sv();
  // One task per (direction, row of samples): rays of a row are spatially coherent.
  parallelForChunks(
      int64_t(m_nDirs) * sv, 4,
      [&](int64_t b, int64_t e) {
        for (int64_t k = b; k < e; ++k) {
          const int d = int(k / sv), row = int(k % sv);
          const DVec3 w = dirs[d].w;
          for (int a = 0; a < su; ++a) {
            const int64_t s = int64_t(row) * su + a;
            float depth;
            const RayHit h = traceSampleRay(tracer, grid.position(a, row), w, &depth);
            const size_t i = idx(d, s);
            m_prim[i] = h.prim;
            m_depth[i] = depth;
            m_u[i] = h.u;
            m_v[i] = h.v;
          }
          if (progress && row == sv - 1) progress->add(1);
        }
      },
      cancel);
}

std::vector<float> HitMaps::vmf(int dir) const {
  const int nu = m_grid.nu, nv = m_grid.nv, K = m_grid.spp;
  std::vector<float> out(size_t(nu) * nv * 2, 0.f);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      int hits = 0;
      double sum = 0;
      for (int s = 0; s < K * K; ++s) {
        const int64_t si = m_grid.sampleIndex(i, j, s);
        if (prim(dir, si) != kNoHit) {
          ++hits;
          sum += depth(dir, si);
        }
      }
      out[(size_t(j) * nu + i) * 2] = float(hits) / float(K * K);
      out[(size_t(j) * nu + i) * 2 + 1] = hits ? float(sum / hits) : 0.f;
    }
  return out;
}

}  // namespace btf
