#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/sim/brdf_probe.h>
#include <btf/sim/hit_maps.h>
#include <btf/sim/shading.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace btf {

DirectionPair pairFromDegrees(double ti, double pi, double to, double po) {
  for (double t : {ti, to})
    if (!std::isfinite(t) || t < 0 || t > kMaxProbeThetaDeg) {
      char b[160];
      std::snprintf(b, sizeof b,
                    "θ must be in [0, %g] degrees (got %.10g): closer to 90° the tile is seen "
                    "edge-on and its value is not resolved in floating point",
                    kMaxProbeThetaDeg, t);
      throw Error(b);
    }
  for (double p : {pi, po})
    if (!std::isfinite(p)) throw Error("φ must be a finite angle in degrees");
  return {sphericalDir(deg2rad(ti), deg2rad(pi)), sphericalDir(deg2rad(to), deg2rad(po))};
}

DirectionPair parsePairText(const std::string& text, const std::string& where,
                            std::array<double, 4>* degrees) {
  std::array<double, 4> v{};
  std::string t = text.substr(0, 4096);
  std::replace(t.begin(), t.end(), ',', ' ');
  std::istringstream in(t);
  std::string rest;
  if (text.size() > 4096 || !(in >> v[0] >> v[1] >> v[2] >> v[3]) || (in >> rest))
    throw Error(where + ": expected θi,φi,θo,φo in degrees, got '" + text.substr(0, 80) +
                (text.size() > 80 ? "...'" : "'"));
  DirectionPair p;
  try {
    p = pairFromDegrees(v[0], v[1], v[2], v[3]);
  } catch (const Error& e) {
    throw Error(where + ": " + e.what());
  }
  if (degrees) *degrees = v;
  return p;
}

std::vector<DirectionPair> parsePairsFile(const std::string& text, const std::string& source,
                                          std::vector<std::array<double, 4>>* degrees) {
  std::vector<DirectionPair> pairs;
  std::istringstream f(text);
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    if (std::isalpha(static_cast<unsigned char>(line[first])) && n == 1) continue;  // header
    if (pairs.size() == kMaxPairs)
      throw Error(source + ":" + std::to_string(n) + ": more than " + std::to_string(kMaxPairs) +
                  " pairs");
    std::array<double, 4> v;
    pairs.push_back(parsePairText(line, source + ":" + std::to_string(n), &v));
    if (degrees) degrees->push_back(v);
  }
  return pairs;
}

DVec3 tilePosition(uint64_t seed, int a, int row, int n, double Lx, double Ly, uint64_t salt) {
  const uint64_t h = hashKeys(seed, uint64_t(a), uint64_t(row), 0xb3d + salt);
  return {(a + uniformFloat(h)) * Lx / n, (row + uniformFloat(mix64(h))) * Ly / n, 0};
}

std::vector<Rgb> reduceRows(const std::vector<Rgb>& partials, size_t pairs, int n, float scale) {
  std::vector<Rgb> out(pairs, Rgb(0));
  for (size_t pi = 0; pi < pairs; ++pi) {
    Rgb acc(0);
    for (int r = 0; r < n; ++r) acc += partials[pi * size_t(n) + size_t(r)];
    out[pi] = acc * scale;
  }
  return out;
}

std::vector<Rgb> averagedBrdf(const PeriodicTracer& tracer, const std::vector<Material>& materials,
                              const std::vector<DirectionPair>& pairs, int n, uint64_t seed,
                              const CancelToken* cancel) {
  if (n < 1) throw Error("samples per axis must be >= 1");
  const TileGeometry& g = tracer.geometry();
  std::vector<Rgb> partials(pairs.size() * size_t(n), Rgb(0));
  parallelForChunks(
      int64_t(pairs.size()) * n, 1,
      [&](int64_t b, int64_t e) {
        for (int64_t k = b; k < e; ++k) {
          const size_t pi = size_t(k / n);
          const int row = int(k % n);
          const DirectionPair& pr = pairs[pi];
          const Vec3 wi(pr.wi), wo(pr.wo);
          const float invCos = 1.0f / float(std::max(pr.wi.z, 1e-7));
          Rgb sum(0);
          for (int a = 0; a < n; ++a) {
            const DVec3 p0 = tilePosition(seed, a, row, n, g.Lx, g.Ly, 0);
            float depth;
            const RayHit hit = traceSampleRay(tracer, p0, pr.wo, &depth);
            if (!hit.hit()) continue;
            Vec3 ng, nS;
            if (!hitNormals(g, hit.prim, hit.u, hit.v, wo, &ng, &nS)) continue;
            const float cosN = glm::dot(nS, wi);
            if (cosN <= 0 || glm::dot(ng, wi) <= 0) continue;
            const DVec3 p = p0 + double(depth) * pr.wo;
            if (tracer.occluded(p + tracer.epsilon() * DVec3(ng), pr.wi)) continue;
            const Frame fr = Frame::fromNormal(nS);
            sum += evalBrdf(materials[g.triMaterial[hit.prim]], fr.toLocal(wi), fr.toLocal(wo)) *
                   (cosN * invCos);
          }
          partials[size_t(k)] = sum;  // per-row partials: deterministic, no atomics
        }
      },
      cancel);
  return reduceRows(partials, pairs.size(), n, 1.0f / float(n) / float(n));
}

}  // namespace btf
