// The BRDF simulation of §2.6.4 without a BTF: the texel-averaged aBRDF (the macro BRDF of the
// tile) at arbitrary direction pairs, from an n×n stratified jittered set of view rays over the
// whole tile with exact shadow rays. What `btfsim brdf` and the studio's live BRDF view call.
#pragma once
#include <btf/core/parallel.h>
#include <btf/scene/material.h>
#include <btf/trace/periodic_tracer.h>

#include <vector>

namespace btf {

struct DirectionPair {
  DVec3 wi, wo;  // toward the light, toward the camera (unit, z > 0)
};

/// Pair from angles in degrees; throws btf::Error for θ outside [0, 90) or non-finite values.
DirectionPair pairFromDegrees(double thetaI, double phiI, double thetaO, double phiO);

/// Averaged aBRDF of each pair with n×n samples; deterministic for a given seed.
std::vector<Rgb> averagedBrdf(const PeriodicTracer& tracer, const std::vector<Material>& materials,
                              const std::vector<DirectionPair>& pairs, int n, uint64_t seed = 1,
                              const CancelToken* cancel = nullptr);

}  // namespace btf
