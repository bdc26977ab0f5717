#include <btf/core/error.h>
#include <btf/sim/path_tracer.h>
#include <btf/sim/shading.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace btf {

namespace {

// Rank r's contiguous share [b, e) of n work items (all of them without a distributed comm).
std::pair<int64_t, int64_t> shareOf(const Comm* comm, int64_t n) {
  if (!comm || !comm->distributed()) return {0, n};
  const int64_t R = comm->size(), r = comm->rank();
  return {n * r / R, n * (r + 1) / R};
}

// Every rank's share of `v` (items of `per` Rgb each, shares as shareOf) sent to every rank.
void gatherShares(Comm* comm, int64_t n, size_t per, std::vector<Rgb>& v) {
  if (!comm || !comm->distributed()) return;
  const auto [b, e] = shareOf(comm, n);
  const std::string mine(reinterpret_cast<const char*>(v.data() + size_t(b) * per),
                         size_t(e - b) * per * sizeof(Rgb));
  const std::vector<std::string> all = comm->allgather(mine);
  const int64_t R = comm->size();
  for (int64_t q = 0; q < R; ++q) {
    const int64_t qb = n * q / R, qe = n * (q + 1) / R;
    if (all[size_t(q)].size() != size_t(qe - qb) * per * sizeof(Rgb))
      throw Error("path-traced reference: rank " + std::to_string(q) + " sent " +
                  std::to_string(all[size_t(q)].size()) + " bytes, expected " +
                  std::to_string(size_t(qe - qb) * per * sizeof(Rgb)));
    std::memcpy(reinterpret_cast<char*>(v.data() + size_t(qb) * per), all[size_t(q)].data(),
                all[size_t(q)].size());
  }
}

}  // namespace

void tracePath(const PeriodicTracer& tracer, const std::vector<Material>& materials,
               const DVec3& p0, const DVec3& wo, const DVec3* lights, int nLights,
               const PathSettings& s, Rng& rng, float weight, Rgb* out) {
  const TileGeometry& g = tracer.geometry();
  const double eps = tracer.epsilon();
  const int limit = s.maxBounces > 0 ? std::min(s.maxBounces, s.hardLimit) : s.hardLimit;
  // First vertex: the texel sample's ray, computed exactly as the hit maps do so that a
  // direct-only path reproduces the direct simulator.
  float depth;
  RayHit hit = traceSampleRay(tracer, p0, wo, &depth);
  if (!hit.hit()) return;
  Vec3 p = Vec3(p0 + double(depth) * wo);
  Vec3 toViewer = Vec3(wo);
  // The path's throughput starts at 1: Russian roulette reads it, so the caller's weight (e.g.
  // 1 / samples) must not enter it — a small weight would end nearly every path at rrDepth and
  // leave the deeper orders to a few survivors scaled by 1 / q (unbiased, but extreme variance).
  Rgb beta(1.0f);
  for (int bounce = 1;; ++bounce) {
    Vec3 ng, n;
    if (!hitNormals(g, hit.prim, hit.u, hit.v, toViewer, &ng, &n)) return;
    const Material& mat = materials[g.triMaterial[hit.prim]];
    const Frame frame = Frame::fromNormal(n);
    const Vec3 woL = frame.toLocal(toViewer);
    const DVec3 origin = DVec3(p) + eps * DVec3(ng);
    for (int l = 0; l < nLights; ++l) {
      const Vec3 wl(lights[l]);
      const float cosN = glm::dot(n, wl);
      if (cosN <= 0 || glm::dot(ng, wl) <= 0) continue;
      if (tracer.occluded(origin, DVec3(wl))) continue;
      const Rgb f = evalBrdf(mat, frame.toLocal(wl), woL);
      out[l] += weight * beta * f * (cosN / float(std::max(lights[l].z, 1e-7)));
    }
    if (bounce >= limit) return;
    const float u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
    const BrdfSample bs = sampleBrdf(mat, woL, u0, u1, u2);
    if (!(bs.pdf > 0)) return;
    const Vec3 wiW = frame.toWorld(bs.wi);
    if (glm::dot(ng, wiW) <= 0) return;  // shading normal sent the path into the surface
    beta *= evalBrdf(mat, bs.wi, woL) * (bs.wi.z / bs.pdf);
    if (bounce >= s.rrDepth) {
      const float q = std::min(0.95f, std::max(beta.x, std::max(beta.y, beta.z)));
      if (!(q > 0) || rng.uniform() >= q) return;
      beta /= q;
    }
    if (!(beta.x > 0 || beta.y > 0 || beta.z > 0)) return;
    const DVec3 dir = glm::normalize(DVec3(wiW));
    hit = tracer.intersect(origin, dir);
    if (!hit.hit()) return;
    p = Vec3(origin + hit.t * dir);
    toViewer = -Vec3(dir);
  }
}

std::vector<Rgb> pathTracedBrdf(const PeriodicTracer& tracer,
                                const std::vector<Material>& materials,
                                const std::vector<DirectionPair>& pairs, int n, int paths,
                                const PathSettings& settings, const CancelToken* cancel,
                                Comm* comm) {
  if (n < 1) throw Error("samples per axis must be >= 1");
  if (paths < 1) throw Error("paths per sample must be >= 1");
  const TileGeometry& g = tracer.geometry();
  std::vector<Rgb> partials(pairs.size() * size_t(n), Rgb(0));
  const int64_t rows = int64_t(pairs.size()) * n;
  const auto [k0, k1] = shareOf(comm, rows);
  parallelForChunks(
      k1 - k0, 1,
      [&](int64_t b, int64_t e) {
        for (int64_t k = k0 + b; k < k0 + e; ++k) {
          const size_t pi = size_t(k / n);
          const int row = int(k % n);
          const DirectionPair& pr = pairs[pi];
          Rgb sum(0);
          for (int a = 0; a < n; ++a)
            for (int q = 0; q < paths; ++q) {
              // Path 0 uses averagedBrdf's positions; further paths are re-jittered.
              const DVec3 p0 = tilePosition(settings.seed, a, row, n, g.Lx, g.Ly, uint64_t(q));
              Rng rng(hashKeys(settings.seed ^ 0x9a7e, pi, uint64_t(row) * uint64_t(n) + a, q));
              tracePath(tracer, materials, p0, pr.wo, &pr.wi, 1, settings, rng, 1.0f, &sum);
            }
          partials[size_t(k)] = sum;
        }
      },
      cancel);
  gatherShares(comm, rows, 1, partials);
  return reduceRows(partials, pairs.size(), n, 1.0f / (float(n) * float(n) * float(paths)));
}

std::vector<Rgb> pathTracedTexels(const PeriodicTracer& tracer,
                                  const std::vector<Material>& materials, const SampleGrid& grid,
                                  const DVec3& wo, const std::vector<DVec3>& lights, int paths,
                                  const PathSettings& settings, const CancelToken* cancel,
                                  Comm* comm) {
  if (paths < 1) throw Error("paths per sample must be >= 1");
  const int nL = int(lights.size());
  const int64_t texels = int64_t(grid.nu) * grid.nv;
  std::vector<Rgb> out(size_t(texels) * size_t(nL), Rgb(0));
  const int K2 = grid.spp * grid.spp;
  const float w = 1.0f / (float(K2) * float(paths));
  const auto [t0, t1] = shareOf(comm, texels);
  parallelForChunks(
      t1 - t0, 4,
      [&](int64_t b, int64_t e) {
        for (int64_t t = t0 + b; t < t0 + e; ++t) {
          const int i = int(t % grid.nu), j = int(t / grid.nu);
          for (int s = 0; s < K2; ++s) {
            const int64_t si = grid.sampleIndex(i, j, s);
            const DVec3 p0 = grid.position(int(si % grid.su()), int(si / grid.su()));
            for (int q = 0; q < paths; ++q) {
              Rng rng(hashKeys(settings.seed ^ 0x7e11, uint64_t(si), uint64_t(q)));
              tracePath(tracer, materials, p0, wo, lights.data(), nL, settings, rng, w,
                        &out[size_t(t) * size_t(nL)]);
            }
          }
        }
      },
      cancel);
  gatherShares(comm, texels, size_t(nL), out);
  return out;
}

}  // namespace btf
