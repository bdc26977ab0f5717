// Unbiased Monte Carlo path tracing of the periodic tile: the reference that the point network
// (and every other approximation) is measured against. Camera and light are directional, as in
// the BTF: a path starts at a point of the reference plane, travels along −ωo to its first hit,
// and at every vertex adds next-event estimation toward the light (the light is a delta, so BRDF
// sampling can never hit it and NEE alone is unbiased); the walk continues by sampling f·cos
// (mixture of the diffuse and glossy lobes' samplers, i.e. the balance heuristic over the two
// techniques), with Russian roulette after a minimum depth. Random numbers are counter-based
// streams keyed by (seed, pair or pixel, sample, path): results do not depend on thread count.
#pragma once
#include <btf/core/comm.h>
#include <btf/core/parallel.h>
#include <btf/core/rng.h>
#include <btf/scene/material.h>
#include <btf/sim/brdf_probe.h>
#include <btf/sim/hit_maps.h>
#include <btf/trace/periodic_tracer.h>

#include <vector>

namespace btf {

struct PathSettings {
  /// Reflections along a path: 1 = direct light only, P = direct + (P − 1) inter-reflections;
  /// 0 = unbounded (Russian roulette ends paths, `hardLimit` bounds them).
  int maxBounces = 0;
  int rrDepth = 3;  // Russian roulette from this many reflections on
  int hardLimit = 256;
  uint64_t seed = 1;
};

/// One path from plane point p0 along −wo, with next-event estimation toward each of `nLights`
/// lights (the walk is shared by all lights; each light's estimate is unbiased). Adds
/// weight · (path radiance / cos θi) — an aBRDF sample — to out[l].
void tracePath(const PeriodicTracer& tracer, const std::vector<Material>& materials,
               const DVec3& p0, const DVec3& wo, const DVec3* lights, int nLights,
               const PathSettings& settings, Rng& rng, float weight, Rgb* out);

/// Texel-averaged aBRDF of each pair from n×n jittered plane positions (the positions of
/// averagedBrdf) and `paths` paths per position.
/// With a distributed `comm` (every rank calls it, with the same arguments) each rank traces a
/// contiguous share of the work (rows of positions; texels) and the shares are allgathered:
/// every rank returns the bytes one process would.
std::vector<Rgb> pathTracedBrdf(const PeriodicTracer& tracer,
                                const std::vector<Material>& materials,
                                const std::vector<DirectionPair>& pairs, int n, int paths,
                                const PathSettings& settings, const CancelToken* cancel = nullptr,
                                Comm* comm = nullptr);

/// Per-texel aBRDF of one view and every light of `lights`, on the simulator's sample grid (same
/// sample positions as the hit maps), `paths` paths per sample: out[(texel * nLights + l)].
std::vector<Rgb> pathTracedTexels(const PeriodicTracer& tracer,
                                  const std::vector<Material>& materials, const SampleGrid& grid,
                                  const DVec3& wo, const std::vector<DVec3>& lights, int paths,
                                  const PathSettings& settings, const CancelToken* cancel = nullptr,
                                  Comm* comm = nullptr);

}  // namespace btf
