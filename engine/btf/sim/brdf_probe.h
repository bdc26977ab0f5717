// The BRDF simulation of §2.6.4 without a BTF: the texel-averaged aBRDF (the macro BRDF of the
// tile) at arbitrary direction pairs, from an n×n stratified jittered set of view rays over the
// whole tile with exact shadow rays. What `btfsim brdf` and the studio's live BRDF view call.
#pragma once
#include <btf/core/parallel.h>
#include <btf/scene/material.h>
#include <btf/trace/periodic_tracer.h>

#include <array>
#include <string>
#include <vector>

namespace btf {

struct DirectionPair {
  DVec3 wi, wo;  // toward the light, toward the camera (unit, z > 0)
};

/// The largest θ (degrees) a probe pair may have: up to it the path tracer and the direct probe
/// stay within their usual time and converge to the grazing limit (tested); beyond it a ray
/// crosses ~10⁵ tiles per unit of height and float positions no longer resolve the tile.
constexpr double kMaxProbeThetaDeg = 89.99;

/// Pair from angles in degrees; throws btf::Error for θ outside [0, kMaxProbeThetaDeg] or
/// non-finite values, naming the limit.
DirectionPair pairFromDegrees(double thetaI, double phiI, double thetaO, double phiO);

/// One pair from its text "θi,φi,θo,φo" (commas or spaces, degrees): btf::Error "WHERE: …".
DirectionPair parsePairText(const std::string& text, const std::string& where,
                            std::array<double, 4>* degrees = nullptr);
/// The pairs of a pairs file's text (docs/cli.md, `brdf --pairs`): one "θi,φi,θo,φo" a line,
/// blank lines and # comments skipped, an optional header line first; at most kMaxPairs.
/// Errors name SOURCE:LINE.
constexpr size_t kMaxPairs = 1u << 20;
std::vector<DirectionPair> parsePairsFile(const std::string& text, const std::string& source,
                                          std::vector<std::array<double, 4>>* degrees = nullptr);

/// Position on the reference plane of cell (a, row) of an n×n grid over the tile, jittered inside
/// its cell by a counter-based hash of (seed, a, row, salt): the positions of every tile-averaged
/// estimate (averagedBrdf, pathTracedBrdf).
DVec3 tilePosition(uint64_t seed, int a, int row, int n, double Lx, double Ly, uint64_t salt);

/// Sum of `n` per-row partials of each pair (partials[pair * n + row]), times `scale`: the fixed
/// summation order keeps the result independent of the thread schedule.
std::vector<Rgb> reduceRows(const std::vector<Rgb>& partials, size_t pairs, int n, float scale);

/// Averaged aBRDF of each pair with n×n samples; deterministic for a given seed.
std::vector<Rgb> averagedBrdf(const PeriodicTracer& tracer, const std::vector<Material>& materials,
                              const std::vector<DirectionPair>& pairs, int n, uint64_t seed = 1,
                              const CancelToken* cancel = nullptr);

}  // namespace btf
