// The adaptive texel sampler (docs/conventions.md, "Tile and texels"): one (texel, view) row of
// lights from the hit map's samples, refined where edges and shadow boundaries cross the texel
// (edge tests, shadow-edge flags, lit texels and lit faces, the face refinement); its working
// state is in adaptive_scratch.h, its statistics in adaptive_stats.cpp.
#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/sim/adaptive.h>

#include "adaptive_scratch.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <vector>

namespace btf {

using namespace adaptivedetail;

AdaptiveTexelSampler::AdaptiveTexelSampler(const PeriodicTracer& tracer,
                                           const std::vector<Material>& materials,
                                           const DirectionSet& dirs, const HitMaps& maps,
                                           const DirectIllumination& direct,
                                           const NetworkGather* gather, AdaptiveSettings settings,
                                           AdaptiveStats* stats)
    : m_tracer(tracer),
      m_dirs(dirs),
      m_maps(maps),
      m_direct(direct),
      m_gather(gather),
      m_settings(settings),
      m_stats(stats) {
  const SampleGrid& g = maps.grid();
  m_mapLevel = adaptiveLevel(g.spp);
  m_maxLevel = adaptiveLevel(settings.maxK);
  if (m_mapLevel < 0 || m_mapLevel > 1)
    throw Error("adaptive sampling needs hit maps of 2×2 or 4×4 samples per texel (got " +
                std::to_string(g.spp) + ")");
  if (m_maxLevel < m_mapLevel)
    throw Error("--max-spp must be a power of two in " + std::to_string(g.spp) + "..64 (got " +
                std::to_string(settings.maxK) + ")");
  m_texelSize = std::max(g.Lx / g.nu, g.Ly / g.nv);
  m_shadowEdges = maps.hasEdgeTables() && direct.settings().shadows != ShadowMode::None;
  m_toSampleX = float(g.su() / g.Lx);
  m_toSampleY = float(g.sv() / g.Ly);
  for (const auto& d : dirs.dirs()) {
    const double c = std::max(d.w.z, 1e-7);
    m_slopeX.push_back(float(d.w.x / c));
    m_slopeY.push_back(float(d.w.y / c));
    m_invCos.push_back(float(1.0 / c));
  }
  // Half the shadow map's smallest bias (DirectIllumination::mapVisibility): a tap this far
  // beyond a receiver still lights it.
  m_litMargin =
      0.125f * direct.settings().biasScale * float(std::max(g.Lx / g.su(), g.Ly / g.sv()));
  // A quarter of the brightest diffuse aBRDF of the scene's materials.
  float brightest = 0;
  for (const Material& m : materials)
    brightest = std::max(brightest, lum(m.kdOverPi) + lum(m.ks) * (1.0f / 3.14159265f));
  m_floor = 0.25f * std::max(brightest, 1e-3f);
}

int64_t AdaptiveTexelSampler::eval(int i, int j, int view, float* out) const {
  thread_local Scratch sc;
  const int nL = m_dirs.size();
  sc.faces.clear();
  auto classify = [&](Sample& S) {
    S.cls = -1;
    if (!S.ok) return;
    const int n = int(sc.faces.size());
    for (int c = 0; c < n; ++c) {
      const Scratch::Face& F = sc.faces[size_t(c)];
      if (F.material == S.s.material && F.n == S.s.n && F.ng == S.s.ng) {
        S.cls = c;
        return;
      }
    }
    if (n < kMaxClasses) {
      sc.faces.push_back({S.s.material, S.s.n, S.s.ng, S.s});
      S.cls = n;
    }
  };
  const SampleGrid& g = m_maps.grid();
  const int Km = g.spp;
  const DVec3 wv = m_dirs[view].w;
  std::fill(out, out + size_t(nL) * 3, 0.0f);

  // The hit map's own level: its samples cost no ray.
  std::vector<Sample>& map = sc.levels[m_mapLevel];
  map.resize(size_t(Km) * Km);
  for (int b = 0; b < Km; ++b)
    for (int a = 0; a < Km; ++a) {
      Sample& S = map[size_t(b) * Km + a];
      const int64_t si = g.sampleIndex(i, j, b * Km + a);
      S.pos = g.position(i * Km + a, j * Km + b);
      S.lx = float(S.pos.x * g.nu / g.Lx - i);
      S.ly = float(S.pos.y * g.nv / g.Ly - j);
      S.inPrev = false;
      S.prevIndex = -1;
      S.si = si;
      S.ok = m_direct.surface(S.pos, wv, m_maps.prim(view, si), m_maps.bu(view, si),
                              m_maps.bv(view, si), m_maps.depth(view, si), &S.s);
      classify(S);
    }
  if (m_mapLevel == 1) {
    // Level 0: one of the map's four samples in each quadrant, chosen per (texel, quadrant).
    std::vector<Sample>& l0 = sc.levels[0];
    l0.resize(4);
    for (int q = 0; q < 4; ++q) {
      const int qa = q & 1, qb = q >> 1;
      const uint64_t c = hashKeys(g.seed, uint64_t(i) * 2 + uint64_t(qa),
                                  uint64_t(j) * 2 + uint64_t(qb), 0x1e7e10) &
                         3;
      const size_t k = size_t(2 * qb + int(c >> 1)) * 4 + size_t(2 * qa + int(c & 1));
      l0[size_t(q)] = map[k];
      l0[size_t(q)].inPrev = false;
      map[k].inPrev = true;
      map[k].prevIndex = q;  // level 0 is stored in quadrant order, a 2×2 stratum grid
    }
  }

  // Does the texel straddle an edge? Between neighbouring map samples: hit and miss, two
  // materials, a crease (shading normals more than 25° apart: a smooth curve turns far less
  // between neighbours a quarter texel apart) or a depth step (off the neighbour's tangent plane
  // by more than a tenth of a texel).
  bool edge = false;
  auto differ = [&](const Sample& A, const Sample& B) {
    if (A.ok != B.ok) return true;
    if (!A.ok) return false;
    return A.s.material != B.s.material || glm::dot(A.s.n, B.s.n) < 0.9f ||
           std::abs(glm::dot(A.s.ng, B.s.p - A.s.p)) > 0.1f * float(m_texelSize);
  };
  for (int b = 0; b < Km && !edge; ++b)
    for (int a = 0; a < Km && !edge; ++a) {
      const Sample& S = map[size_t(b) * Km + a];
      edge = (a + 1 < Km && differ(S, map[size_t(b) * Km + a + 1])) ||
             (b + 1 < Km && differ(S, map[size_t(b + 1) * Km + a]));
    }
  // An edge just outside the map's samples (a sliver they all missed): the view's edge table
  // over the texel and a guard band of one map sample.
  const bool edgeBySamples = edge;
  if (!edge && m_maps.hasEdgeTables())
    edge = m_maps.edgeCount(view, i * Km - 1, (i + 1) * Km + 1, j * Km - 1, (j + 1) * Km + 1) > 0;

  // Shadow boundaries: a light whose hit map (= its shadow map) has a discontinuity inside the
  // footprint of a quadrant of the texel — the receivers of the quadrant swept along −ωi to
  // the light's map, widened by a map sample — is flagged for that quadrant: the quadrant
  // splits to the map's level, its cells whose own footprint holds the edge split once more
  // (a sliver of light or shadow that every sample of the cell missed would otherwise bias the
  // texel), and samples the map cannot decide (its taps disagree) take an exact shadow ray:
  // the map places a boundary only within ±½ map sample.
  int okCount = 0;
  for (const Sample& S : map) okCount += S.ok;
  // Heights of the receivers of cell (c, r) of a level with K ≤ Km cells per side.
  auto zRange = [&](int K, int c, int r, float* lo, float* hi) {
    const int w = Km / K;
    *lo = INFINITY, *hi = -INFINITY;
    for (int b = r * w; b < (r + 1) * w; ++b)
      for (int a = c * w; a < (c + 1) * w; ++a) {
        const Sample& S = map[size_t(b) * Km + a];
        if (S.ok) *lo = std::min(*lo, S.s.p.z), *hi = std::max(*hi, S.s.p.z);
      }
    return *lo <= *hi;
  };
  // The map-sample rectangle of the texel-local rectangle [x0, x1] × [y0, y1] swept along −ω
  // over heights [zlo, zhi] (slopes sx, sy in samples per unit height), widened by `pad`
  // samples.
  struct Rect {
    int a0, a1, b0, b1;
  };
  auto footprint = [&](float x0, float x1, float y0, float y1, float sx, float sy, float zlo,
                       float zhi, float pad) {
    const float a0 = (float(i) + x0) * float(Km) - std::max(zlo * sx, zhi * sx) - pad;
    const float a1 = (float(i) + x1) * float(Km) - std::min(zlo * sx, zhi * sx) + pad;
    const float b0 = (float(j) + y0) * float(Km) - std::max(zlo * sy, zhi * sy) - pad;
    const float b1 = (float(j) + y1) * float(Km) - std::min(zlo * sy, zhi * sy) + pad;
    return Rect{int(std::floor(a0)), int(std::ceil(a1)), int(std::floor(b0)), int(std::ceil(b1))};
  };
  // Edge samples of the view's table in a texel-local rectangle, widened by one sample.
  auto viewEdgesIn = [&](float x0, float x1, float y0, float y1) {
    const Rect r = footprint(x0, x1, y0, y1, 0, 0, 0, 0, 1.0f);
    return m_maps.hasEdgeTables() && m_maps.edgeCount(view, r.a0, r.a1, r.b0, r.b1) > 0;
  };
  // The same per cell of level L (light-independent: computed once per (texel, view)).
  for (auto& v : sc.cellEdge) v.clear();
  auto cellEdge = [&](int L, int k) {
    std::vector<int8_t>& v = sc.cellEdge[L];
    const int K = 2 << L;
    if (v.empty()) v.assign(size_t(K) * K, -1);
    if (v[size_t(k)] < 0) {
      const float inv = 1.0f / float(K);
      const int c = k % K, r = k / K;
      v[size_t(k)] = viewEdgesIn(c * inv, (c + 1) * inv, r * inv, (r + 1) * inv);
    }
    return v[size_t(k)] != 0;
  };
  // A receiver seen through plane point x at height z lies at x + z·sv (sv: the view's slope,
  // ω.xy / ω.z); light l's map holds it at x + z·(sv − sl). In map samples per unit height:
  const float vsx = m_slopeX[size_t(view)], vsy = m_slopeY[size_t(view)];
  auto lightSlopeX = [&](int l) { return (m_slopeX[size_t(l)] - vsx) * m_toSampleX; };
  auto lightSlopeY = [&](int l) { return (m_slopeY[size_t(l)] - vsy) * m_toSampleY; };
  // Something in light l's map over footprint r (widened by one more sample: the map's 3 × 3
  // taps reach that far) lies above height zlo, beyond half the map's smallest bias.
  auto above = [&](int l, const Rect& r, float zlo) {
    return m_maps.maxDepth(l, r.a0 - 1, r.a1 + 1, r.b0 - 1, r.b1 + 1) >
           zlo * m_invCos[size_t(l)] + m_litMargin;
  };
  // Light l's footprint of the whole texel's receivers at heights [zlo, zhi].
  auto texelFootprint = [&](int l, float zlo, float zhi) {
    return footprint(0.0f, 1.0f, 0.0f, 1.0f, lightSlopeX(l), lightSlopeY(l), zlo, zhi, 1.0f);
  };
  // Can light l's visibility change across the receivers of a texel-local rectangle at
  // heights [zlo, zhi]? Only where its map holds an edge in their footprint (a silhouette seen
  // from the light; also material edges: they refine the texel's own edges for this light, which
  // keeps cones and bumps within 1 % of the path tracer), and something there lies above the
  // lowest receiver (`above`): a receiver on top of an occluder sees the occluder's own outline
  // in the map, lit on both sides.
  auto shadowIn = [&](int l, float x0, float x1, float y0, float y1, float zlo, float zhi) {
    const float sx = lightSlopeX(l), sy = lightSlopeY(l);
    const Rect r = footprint(x0, x1, y0, y1, sx, sy, zlo, zhi, 1.0f);
    return m_maps.edgeCount(l, r.a0, r.a1, r.b0, r.b1) && above(l, r, zlo);
  };
  sc.flagged.assign(size_t(nL), 0);
  float qlo[4], qhi[4];
  bool qok[4];
  for (int q = 0; q < 4; ++q) qok[q] = zRange(2, q & 1, q >> 1, &qlo[q], &qhi[q]);
  float tlo = INFINITY, thi = -INFINITY;
  for (int q = 0; q < 4; ++q)
    if (qok[q]) tlo = std::min(tlo, qlo[q]), thi = std::max(thi, qhi[q]);
  // Lights that light every receiver of the texel: nothing in the map over the receivers'
  // footprint lies above the lowest of them (the flat top of a wall, an open floor). Their
  // samples take no visibility test (at heights within the map samples' range, the footprint's).
  // Without self-shadowing every light lights every receiver.
  sc.lit.assign(size_t(nL), m_direct.settings().shadows == ShadowMode::None && okCount ? 1 : 0);
  const float zTol = 1e-6f * float(m_texelSize);
  const float planeTol = 1e-3f * float(m_texelSize);
  // Receivers at the tile's highest height have nothing above them: every light lights them,
  // no map to query (the tops of brick's bricks).
  const float zTop = m_tracer.geometry().zmax - zTol;
  if (m_shadowEdges && okCount && tlo >= zTop) std::fill(sc.lit.begin(), sc.lit.end(), uint8_t(1));
  // Light l with the texel's receivers at heights [lo, hi] and its quadrants' at qlo … qhi:
  // lit, or flagged for the quadrants whose footprint holds a shadow edge.
  auto testLight = [&](int l, float lo, float hi, const float* ql, const float* qh) {
    const Rect r = texelFootprint(l, lo, hi);
    if (!above(l, r, lo)) {
      sc.lit[size_t(l)] = 1;
      return;
    }
    // The whole texel first: most other lights have no shadow edge near it either.
    if (!m_maps.edgeCount(l, r.a0, r.a1, r.b0, r.b1)) return;
    for (int q = 0; q < 4; ++q)
      if (qok[q] && shadowIn(l, 0.5f * float(q & 1), 0.5f * float((q & 1) + 1),
                             0.5f * float(q >> 1), 0.5f * float((q >> 1) + 1), ql[q], qh[q]))
        sc.flagged[size_t(l)] |= uint8_t(1u << q);
  };
  for (int l = 0; l < nL && m_shadowEdges && okCount && tlo < zTop; ++l)
    testLight(l, tlo, thi, qlo, qhi);

  // A sample's contribution for light l: its face's unshadowed value (once per face and light:
  // samples of one flat face share it) times its visibility (flagged lights: exact shadow rays
  // where the map's taps disagree).
  if (++sc.stamp == 0) std::fill(sc.classStamp.begin(), sc.classStamp.end(), 0u), sc.stamp = 1;
  if (sc.classStamp.size() < size_t(kMaxClasses) * nL) {
    sc.classStamp.assign(size_t(kMaxClasses) * nL, 0u);
    sc.classValue.resize(size_t(kMaxClasses) * nL);
  }
  sc.notLit.assign(size_t(nL), 0);
  constexpr uint32_t kMissBit = 1u << kMaxClasses;
  sc.certified.assign(size_t(nL), kMissBit);
  // A sample on the plane its face's samples shared when the face was certified.
  auto onPlane = [&](const Sample& S) {
    const size_t c = size_t(S.cls);
    return c < sc.facePlanar.size() && sc.facePlanar[c] &&
           std::abs(glm::dot(sc.faces[c].ng, S.s.p) - sc.faceOffset[c]) <= planeTol;
  };
  auto faceValue = [&](int c, int l) -> const Rgb& {
    const size_t k = size_t(c) * size_t(nL) + size_t(l);
    if (sc.classStamp[k] != sc.stamp) {
      sc.classValue[k] = m_direct.unshadowed(sc.faces[size_t(c)].s, l);
      sc.classStamp[k] = sc.stamp;
    }
    return sc.classValue[k];
  };
  auto contrib = [&](const Sample& S, int l, uint8_t* open) -> Rgb {
    *open = 0;
    const Rgb f = S.cls >= 0 ? faceValue(S.cls, l) : m_direct.unshadowed(S.s, l);
    if (f.x == 0 && f.y == 0 && f.z == 0) return f;
    if (sc.lit[size_t(l)] && S.s.p.z >= tlo - zTol && S.s.p.z <= thi + zTol) return f;
    if (S.cls >= 0 && (sc.certified[size_t(l)] >> S.cls & 1u) && onPlane(S)) return f;
    bool decided = true;
    const float v = m_direct.visibility(S.s, l, sc.flagged[size_t(l)] != 0, &decided);
    if (!decided || v < 1.0f) sc.notLit[size_t(l)] = 1;
    *open = !decided;
    return f * v;
  };

  uint64_t rays = 0;
  // The four children of cell k of level L (the one holding the parent's sample keeps it), at
  // level L + 1: fresh camera rays, traced once per (texel, view) and shared by every light.
  for (int L = m_mapLevel; L + 1 < AdaptiveStats::kLevels; ++L)
    sc.built[L].assign(size_t(2 << L) * size_t(2 << L), 0);
  auto buildChildren = [&](int L, int k) {
    if (sc.built[L][size_t(k)]) return;
    sc.built[L][size_t(k)] = 1;
    const int K = 2 << L, K2 = 2 * K;
    std::vector<Sample>& nxt = sc.levels[L + 1];
    nxt.resize(size_t(K2) * K2);
    const int pi = k % K, pj = k / K;
    const Sample& ps = sc.levels[L][size_t(k)];
    const int cx = std::clamp(int(ps.lx * float(K2)), 2 * pi, 2 * pi + 1);
    const int cy = std::clamp(int(ps.ly * float(K2)), 2 * pj, 2 * pj + 1);
    for (int d = 0; d < 4; ++d) {
      const int ci = 2 * pi + (d & 1), cj = 2 * pj + (d >> 1);
      Sample& cs = nxt[size_t(cj) * K2 + ci];
      if (ci == cx && cj == cy) {
        cs = ps;
        cs.inPrev = true;
        cs.prevIndex = k;
        continue;
      }
      const uint64_t h = hashKeys(g.seed ^ 0xada97a1e5ull, uint64_t(i) * K2 + uint64_t(ci),
                                  uint64_t(j) * K2 + uint64_t(cj), uint64_t(L + 1));
      cs.lx = (float(ci) + uniformFloat(h)) / float(K2);
      cs.ly = (float(cj) + uniformFloat(mix64(h))) / float(K2);
      cs.pos = DVec3((i + double(cs.lx)) * g.Lx / g.nu, (j + double(cs.ly)) * g.Ly / g.nv, 0.0);
      float depth;
      const RayHit hit = traceSampleRay(m_tracer, cs.pos, wv, &depth);
      ++rays;
      cs.inPrev = false;
      cs.prevIndex = -1;
      cs.si = -1;
      cs.ok = hit.hit() && m_direct.surface(cs.pos, wv, hit.prim, hit.u, hit.v, depth, &cs.s);
      classify(cs);
    }
  };

  // Lights that light the whole texel, where it shows flat faces only: the value is Σ over the
  // faces of (area fraction × the face's unshadowed value), closed form. The area fractions are
  // the light's business only through the face values, so they come from one refinement per
  // (texel, view): from the map's samples, cells whose sample sees another face (or a miss)
  // than a neighbour's split, with their four neighbours, down to the finest level.
  sc.samplesUsed.assign(size_t(nL), 4);
  sc.finalLevel.assign(size_t(nL), 0);
  sc.err.assign(size_t(nL), 0.f);
  bool closed = false;  // some light may take the closed form
  for (int l = 0; l < nL; ++l) closed = closed || sc.lit[size_t(l)] || sc.flagged[size_t(l)];
  for (const Sample& S : map) closed = closed && (!S.ok || S.cls >= 0);
  int gFinal = m_mapLevel, leaves = int(map.size());
  sc.geoExtra.clear();
  if (closed) {
    const int n0 = int(map.size());
    sc.rep.resize(size_t(n0));
    sc.exists.assign(size_t(n0), 1);
    sc.repLevel.assign(size_t(n0), int8_t(m_mapLevel));
    for (int k = 0; k < n0; ++k) sc.rep[size_t(k)] = &map[size_t(k)];
    auto face = [](const Sample* S) { return S->ok ? S->cls : kMaxClasses; };
    for (int L = m_mapLevel; L < m_maxLevel && closed; ++L) {
      const int K = 2 << L, n = K * K;
      sc.hot.assign(size_t(n), 0);
      forNeighbourPairs(K, [&](int k, int o) {
        if ((sc.exists[size_t(k)] || sc.exists[size_t(o)]) &&
            face(sc.rep[size_t(k)]) != face(sc.rep[size_t(o)]))
          sc.hot[size_t(k)] = sc.hot[size_t(o)] = 1;
      });
      bool any = false;
      for (int r = 0; r < K && closed; ++r)
        for (int c = 0; c < K && closed; ++c) {
          const int k = r * K + c;
          if (!sc.exists[size_t(k)] || !(hotOrNeighbour(sc.hot, K, c, r) ||
                                         (m_settings.edgeCells && edge && cellEdge(L, k))))
            continue;
          buildChildren(L, k);
          any = true;
          leaves += 3;
          for (int d = 0; d < 4; ++d) {
            const int c2 = (2 * (k / K) + (d >> 1)) * (2 * K) + 2 * (k % K) + (d & 1);
            if (!sc.levels[L + 1][size_t(c2)].inPrev) sc.geoExtra.push_back({L + 1, c2});
          }
          const int K2 = 2 * K;
          for (int d = 0; d < 4; ++d) {
            const Sample& cs = sc.levels[L + 1][size_t(2 * (k / K) + (d >> 1)) * K2 +
                                                size_t(2 * (k % K) + (d & 1))];
            closed = closed && (!cs.ok || cs.cls >= 0);  // a face beyond the table: per sample
          }
        }
      if (!any || !closed) break;
      const int K2 = 2 * K, n2 = K2 * K2;
      sc.nextRep.resize(size_t(n2));
      sc.nextExists.assign(size_t(n2), 0);
      sc.nextRepLevel.resize(size_t(n2));
      for (int cj = 0; cj < K2; ++cj)
        for (int ci = 0; ci < K2; ++ci) {
          const int k = (cj / 2) * K + ci / 2, c2 = cj * K2 + ci;
          if (sc.exists[size_t(k)] && sc.built[L][size_t(k)]) {
            sc.nextRep[size_t(c2)] = &sc.levels[L + 1][size_t(c2)];
            sc.nextExists[size_t(c2)] = 1;
            sc.nextRepLevel[size_t(c2)] = int8_t(L + 1);
          } else {
            sc.nextRep[size_t(c2)] = sc.rep[size_t(k)];
            sc.nextRepLevel[size_t(c2)] = sc.repLevel[size_t(k)];
          }
        }
      std::swap(sc.rep, sc.nextRep);
      std::swap(sc.exists, sc.nextExists);
      std::swap(sc.repLevel, sc.nextRepLevel);
      gFinal = L + 1;
    }
  }
  int64_t evals = 0;
  if (closed) {
    // Area per face over the final grid, and the neighbouring pairs of different faces (the
    // error estimate: the per-light rule's neighbour differences on the same grid).
    const int K = 2 << gFinal, n = K * K;
    const int nFaces = int(sc.faces.size());
    sc.area.assign(size_t(nFaces), 0.f);
    for (int k = 0; k < n; ++k)
      if (sc.rep[size_t(k)]->ok) sc.area[size_t(sc.rep[size_t(k)]->cls)] += 1.0f;
    sc.facePairs.clear();
    auto face = [](const Sample* S) { return S->ok ? S->cls : -1; };
    forNeighbourPairs(K, [&](int k, int o) {
      if (!sc.exists[size_t(k)] && !sc.exists[size_t(o)]) return;
      int a = face(sc.rep[size_t(k)]), b = face(sc.rep[size_t(o)]);
      if (a == b) return;
      if (a > b) std::swap(a, b);
      for (auto& fp : sc.facePairs)
        if (fp[0] == a && fp[1] == b) return void(++fp[2]);
      sc.facePairs.push_back({a, b, 1});
    });
  }
  // The refinement may show receivers beyond the map samples' heights (the lower part of a
  // wall that one map sample touched at its top): a light that lit [tlo, thi] takes the closed
  // form only if it lights them too; else it is tested again over the whole range, like the
  // others (its faces may still be certified below).
  if (closed && m_shadowEdges && !sc.geoExtra.empty()) {
    float rlo = tlo, rhi = thi;
    for (const auto& e : sc.geoExtra) {
      const Sample& S = sc.levels[e[0]][size_t(e[1])];
      if (S.ok) rlo = std::min(rlo, S.s.p.z), rhi = std::max(rhi, S.s.p.z);
    }
    if (rlo < tlo - zTol || rhi > thi + zTol) {
      const float rl[4] = {rlo, rlo, rlo, rlo}, rh[4] = {rhi, rhi, rhi, rhi};
      for (int l = 0; l < nL; ++l)
        if (sc.lit[size_t(l)] && rlo < zTop) {
          sc.lit[size_t(l)] = 0;
          testLight(l, rlo, rhi, rl, rh);
        }
    }
  }
  // Faces lit wherever they lie in the texel, per light: a flat face (its samples on one plane)
  // whose receivers over the whole texel — the plane's heights at the texel's corners, within
  // the tile's — have nothing above the lowest of them in the light's map, like the lit test
  // above; or a face the light does not reach (its value is 0 either way). Their samples take no
  // visibility test, and the light's cells that hold only such faces stop refining; the light's
  // value then merges its own grid with the face refinement's (finishLight below).
  sc.facePlanar.clear();
  bool anyCertified = false;
  if (closed && m_shadowEdges && edge == edgeBySamples) {
    const int nFaces = int(sc.faces.size());
    sc.facePlanar.assign(size_t(nFaces), 1);
    sc.faceOffset.assign(size_t(nFaces), 0.f);
    sc.faceLo.assign(size_t(nFaces), INFINITY);
    sc.faceHi.assign(size_t(nFaces), -INFINITY);
    for (int f = 0; f < nFaces; ++f)
      sc.faceOffset[size_t(f)] = glm::dot(sc.faces[size_t(f)].ng, sc.faces[size_t(f)].s.p);
    auto onFacePlane = [&](const Sample& S) {
      if (S.ok && S.cls >= 0 && !onPlane(S)) sc.facePlanar[size_t(S.cls)] = 0;
    };
    for (const Sample& S : map) onFacePlane(S);
    for (const auto& e : sc.geoExtra) onFacePlane(sc.levels[e[0]][size_t(e[1])]);
    // The plane's heights under the texel's corners, seen along the view.
    const float zmin = m_tracer.geometry().zmin, zmax = m_tracer.geometry().zmax;
    for (int f = 0; f < nFaces; ++f) {
      const Vec3 n = sc.faces[size_t(f)].ng;
      const float nv = glm::dot(n, Vec3(wv));
      if (!sc.facePlanar[size_t(f)] || std::abs(nv) < 1e-3f) {
        sc.facePlanar[size_t(f)] = 0;
        continue;
      }
      for (int c = 0; c < 4; ++c) {
        const float X = float((i + (c & 1)) * g.Lx / g.nu), Y = float((j + (c >> 1)) * g.Ly / g.nv);
        const float z = (sc.faceOffset[size_t(f)] - n.x * X - n.y * Y) / nv * float(wv.z);
        sc.faceLo[size_t(f)] = std::min(sc.faceLo[size_t(f)], z);
        sc.faceHi[size_t(f)] = std::max(sc.faceHi[size_t(f)], z);
      }
      sc.faceLo[size_t(f)] = std::max(sc.faceLo[size_t(f)], zmin);
      sc.faceHi[size_t(f)] = std::min(sc.faceHi[size_t(f)], zmax);
      if (sc.faceLo[size_t(f)] > sc.faceHi[size_t(f)]) sc.facePlanar[size_t(f)] = 0;
    }
    // The faces each cell's leaves see, level by level up to the refinement's.
    {
      const int K = 2 << gFinal;
      for (int L = 0; L <= gFinal; ++L) sc.cellFaces[L].assign(size_t(4) << (2 * L), 0u);
      for (int k = 0; k < K * K; ++k) {
        const Sample* S = sc.rep[size_t(k)];
        const uint32_t bit = S->ok ? 1u << S->cls : kMissBit;
        const int c = k % K, r = k / K;
        for (int L = 0; L <= gFinal; ++L) {
          const int sh = gFinal - L, KL = 2 << L;
          sc.cellFaces[L][size_t(r >> sh) * KL + size_t(c >> sh)] |= bit;
        }
      }
    }
    uint32_t present = 0;
    for (uint32_t m : sc.cellFaces[0]) present |= m;
    for (int l = 0; l < nL; ++l) {
      if (sc.lit[size_t(l)]) continue;
      uint32_t cert = kMissBit;
      for (int f = 0; f < nFaces; ++f) {
        if (!(present >> f & 1u)) continue;
        const Rgb& u = faceValue(f, l);
        if (u.x == 0 && u.y == 0 && u.z == 0) {
          cert |= 1u << f;
          continue;
        }
        if (!sc.facePlanar[size_t(f)]) continue;
        const float zlo = sc.faceLo[size_t(f)];
        if (zlo >= zTop || !above(l, texelFootprint(l, zlo, sc.faceHi[size_t(f)]), zlo))
          cert |= 1u << f;
      }
      sc.certified[size_t(l)] = cert;
      if ((present & ~cert) == 0) sc.lit[size_t(l)] = 2;  // every face it lights is lit
      anyCertified = anyCertified || cert != kMissBit;
    }
  }
  // Cell k of level L of a light holds only faces the light lights wherever they lie.
  auto settledCell = [&](int l, int L, int k, int face) {
    const uint32_t cert = sc.certified[size_t(l)];
    if (cert == kMissBit) return false;
    const uint32_t bit = face >= 0 ? 1u << face : face == -1 ? kMissBit : 0xffffffffu;
    uint32_t m = bit;
    if (L <= gFinal) {
      m |= sc.cellFaces[L][size_t(k)];
    } else {
      const int K = 2 << L, sh = L - gFinal, KF = 2 << gFinal;
      m |= sc.cellFaces[gFinal][size_t((k / K) >> sh) * KF + size_t((k % K) >> sh)];
    }
    return (m & ~cert) == 0;
  };
  auto closedForm = [&](int l) {
    const int K = 2 << gFinal, n = K * K;
    const int nFaces = int(sc.faces.size());
    Rgb sum(0);
    for (int f = 0; f < nFaces; ++f) {
      if (sc.area[size_t(f)] == 0) continue;
      sum += faceValue(f, l) * sc.area[size_t(f)];
      ++evals;
    }
    sum /= float(n);
    out[3 * l] = sum.x, out[3 * l + 1] = sum.y, out[3 * l + 2] = sum.z;
    double d2 = 0;
    for (const auto& fp : sc.facePairs) {
      const float ya = fp[0] < 0 ? 0.0f : lum(faceValue(fp[0], l));
      const float yb = lum(faceValue(fp[1], l));
      d2 += double(fp[2]) * double(ya - yb) * double(ya - yb);
    }
    sc.err[size_t(l)] = float(0.5 * std::sqrt(d2) / double(n));
    sc.finalLevel[size_t(l)] = gFinal;
    sc.samplesUsed[size_t(l)] = leaves;
  };
  if (closed)
    for (int l = 0; l < nL; ++l)
      if (sc.lit[size_t(l)]) closedForm(l);

  // The other lights start from level 0. Per light and level, a K×K array of cells: the
  // luminance and RGB of the cell's own sample ("real" cells) or, where a coarser cell was not
  // split, of that cell's sample (a stratum of the coarser level). The estimate is the mean over
  // cells.
  sc.active.clear();
  for (int l = 0; l < nL; ++l)
    if (!closed || !sc.lit[size_t(l)]) sc.active.push_back(l);
  const int nA0 = int(sc.active.size());
  sc.cellY.assign(size_t(nA0) * 4, 0.f);
  sc.cellRgb.assign(size_t(nA0) * 4, Rgb(0));
  sc.cellReal.assign(size_t(nA0) * 4, 1);
  sc.cellFace.assign(size_t(nA0) * 4, int8_t(-1));
  sc.cellLevel.assign(size_t(nA0) * 4, int8_t(0));
  auto faceOf = [](const Sample& S) { return int8_t(!S.ok ? -1 : S.cls >= 0 ? S.cls : -2); };
  // Light by light: one light's shadow-map taps for the four samples share cache lines.
  for (int q = 0; q < 4; ++q) evals += sc.levels[0][size_t(q)].ok ? nA0 : 0;
  for (int a = 0; a < nA0; ++a)
    for (int q = 0; q < 4; ++q) {
      const int l = sc.active[size_t(a)];
      const Sample& S = sc.levels[0][size_t(q)];
      if (!S.ok) continue;
      sc.cellFace[size_t(a) * 4 + size_t(q)] = faceOf(S);
      uint8_t open;
      const Rgb c = contrib(S, l, &open);
      sc.cellReal[size_t(a) * 4 + size_t(q)] = uint8_t(1 + open);
      sc.cellRgb[size_t(a) * 4 + size_t(q)] = c;
      sc.cellY[size_t(a) * 4 + size_t(q)] = lum(c);
    }
  const float tol = m_settings.tolerance;
  auto threshold = [&](float mean) { return tol * std::max(std::abs(mean), m_floor); };

  // Level by level: each active light splits the cells that need it; the others stop.
  auto finishLight = [&](int l, const Rgb* cells, const int8_t* levels, int n) {
    Rgb sum(0);
    if (closed && sc.certified[size_t(l)] != kMissBit) {
      // The light's cells hold only faces it lights did not refine: over the finer of the
      // light's grid and the face refinement's, each cell takes the sample that covers the
      // smaller cell — the light's where it refined (shadow edges), the refinement's where it
      // did (the faces' outlines; a visibility test only off the lit faces).
      const int K = int(std::lround(std::sqrt(double(n)))), KF = 2 << gFinal;
      const int N = std::max(K, KF);
      sc.merged.clear();
      for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
          const size_t lc = size_t(y * K / N) * K + size_t(x * K / N);
          const size_t fc = size_t(y * KF / N) * KF + size_t(x * KF / N);
          if (levels[lc] >= sc.repLevel[fc]) {
            sum += cells[lc];
            continue;
          }
          const Sample* S = sc.rep[fc];
          if (!S->ok) continue;
          const Rgb* v = nullptr;
          for (const auto& m : sc.merged)
            if (m.first == S) v = &m.second;
          if (!v) {
            uint8_t open;
            sc.merged.push_back({S, contrib(*S, l, &open)});
            ++evals;
            v = &sc.merged.back().second;
          }
          sum += *v;
        }
      sum /= float(N * N);
    } else {
      for (int k = 0; k < n; ++k) sum += cells[k];
      sum /= float(n);
    }
    out[3 * l] = sum.x, out[3 * l + 1] = sum.y, out[3 * l + 2] = sum.z;
  };
  for (int L = 0; !sc.active.empty(); ++L) {
    const int K = 2 << L, n = K * K;
    const int nA = int(sc.active.size());
    // 1. Which cells of each active light split.
    sc.split.assign(size_t(nA) * n, 0);
    std::vector<int>& keep = sc.keep;
    keep.clear();
    sc.kept.assign(size_t(nA), 0);
    for (int a = 0; a < nA; ++a) {
      const int l = sc.active[size_t(a)];
      // A flagged light that lit every sample so far, each decided by the map's taps (no shadow
      // edge between them, where the taps of neighbouring samples overlap): the closed form.
      // The refinement's own samples beyond the map's level must be lit and decided too.
      auto litBeyond = [&]() {
        for (const auto& e : sc.geoExtra) {
          const Sample& S = sc.levels[e[0]][size_t(e[1])];
          if (!S.ok) continue;
          const Rgb& f = faceValue(S.cls, l);
          if (f.x == 0 && f.y == 0 && f.z == 0) continue;
          bool decided = true;
          if (m_direct.visibility(S.s, l, true, &decided) < 1.0f || !decided) return false;
        }
        return true;
      };
      if (L == m_mapLevel && closed && sc.flagged[size_t(l)] && !sc.notLit[size_t(l)] &&
          !m_direct.exactRays(l) && litBeyond()) {
        closedForm(l);
        sc.kept[size_t(a)] = 2;
        continue;
      }
      const float* y = &sc.cellY[size_t(a) * n];
      const uint8_t* real = &sc.cellReal[size_t(a) * n];
      double sumY = 0, d2 = 0;
      for (int k = 0; k < n; ++k) sumY += y[k];
      const float mean = float(sumY / n);
      // The error of this level from the differences of neighbouring cells (pairs with a real
      // cell): a step of height c across K×K strata leaves ~0.4 c K^-1.5, what this gives.
      for (int r = 0; r < K; ++r)
        for (int c = 0; c < K; ++c) {
          const int k = r * K + c;
          if (c + 1 < K && (real[k] || real[k + 1]))
            d2 += double(y[k] - y[k + 1]) * (y[k] - y[k + 1]);
          if (r + 1 < K && (real[k] || real[k + K]))
            d2 += double(y[k] - y[k + K]) * (y[k] - y[k + K]);
        }
      const float e = float(0.5 * std::sqrt(d2) / double(n));
      sc.err[size_t(l)] = e;
      sc.finalLevel[size_t(l)] = L;
      if (L == m_maxLevel) continue;
      const float thr = threshold(mean);
      const bool byValue = e > thr;
      const unsigned flags = sc.flagged[size_t(l)];
      // Level 0 → the map's level is free of camera rays: a geometric edge of the texel takes
      // every cell there, a shadow edge the cells of its quadrants. At the map's level the cells
      // of a flagged quadrant whose own footprint holds the shadow edge split; with edge_cells
      // also those holding a geometric edge: slivers every map sample missed (exact area
      // fractions).
      const bool byEdges =
          (L == 0 && (edge || flags)) ||
          (L <= m_mapLevel && (flags || (m_settings.edgeCells && edge && byValue)));
      if (!byValue && !byEdges) continue;
      uint8_t* sp = &sc.split[size_t(a) * n];
      bool any = false;
      const float inv = 1.0f / float(K);
      if (byValue) {
        // Cells that differ from a neighbour (an edge or a lobe passes between them), and their
        // four neighbours: the edge may clip a neighbour whose own sample agrees.
        sc.hot.assign(size_t(n), 0);
        for (int r = 0; r < K; ++r)
          for (int c = 0; c < K; ++c) {
            const int k = r * K + c;
            if (c + 1 < K && std::abs(y[k] - y[k + 1]) > thr) sc.hot[k] = sc.hot[k + 1] = 1;
            if (r + 1 < K && std::abs(y[k] - y[k + K]) > thr) sc.hot[k] = sc.hot[k + K] = 1;
          }
      }
      for (int r = 0; r < K; ++r)
        for (int c = 0; c < K; ++c) {
          const int k = r * K + c;
          if (!real[k] || (anyCertified && settledCell(l, L, k, sc.cellFace[size_t(a) * n + k])))
            continue;
          bool s = false;
          if (byValue) s = hotOrNeighbour(sc.hot, K, c, r);
          // The cell's quadrant (level 0: the cell itself).
          const unsigned quadrant = 1u << ((c * 2 / K) + 2 * (r * 2 / K));
          if (!s && byEdges && L == 0) s = edge || (flags & quadrant);
          if (!s && byEdges && L > 0) {
            const float x0 = c * inv, x1 = (c + 1) * inv, y0 = r * inv, y1 = (r + 1) * inv;
            float zl, zh;
            // A flagged quadrant's cell splits where the shadow edge may cross it: for a flat
            // cell lit through the map, where the map's taps around its sample disagreed; else
            // where its receivers' footprint in the light's map holds a shadow edge.
            const bool edgeCell = edge && cellEdge(L, k);
            s = (m_settings.edgeCells && byValue && edgeCell) ||
                ((flags & quadrant) &&
                 (edgeCell || m_direct.exactRays(l)
                      ? zRange(K, c, r, &zl, &zh) && shadowIn(l, x0, x1, y0, y1, zl, zh)
                      : real[k] == 2));
          }
          sp[k] = s;
          any = any || s;
        }
      if (any) keep.push_back(a), sc.kept[size_t(a)] = 1;
    }
    // The lights that stop here keep this level's estimate.
    for (int a = 0; a < nA; ++a)
      if (!sc.kept[size_t(a)])
        finishLight(sc.active[size_t(a)], &sc.cellRgb[size_t(a) * n], &sc.cellLevel[size_t(a) * n],
                    n);
    if (keep.empty()) break;

    // 2. The next level's samples where some light splits a cell (fresh camera rays beyond
    // the map's level, traced once and shared by every light).
    const int K2 = 2 * K, n2 = K2 * K2;
    std::vector<Sample>& nxt = sc.levels[L + 1];
    if (L + 1 > m_mapLevel) {
      sc.made.assign(size_t(n), 0);
      for (int a : keep)
        for (int k = 0; k < n; ++k) sc.made[size_t(k)] |= sc.split[size_t(a) * n + k];
      for (int k = 0; k < n; ++k)
        if (sc.made[size_t(k)]) buildChildren(L, k);
    }

    // 3. Each light that splits moves to the next level: split cells get their four children's
    // samples (the parent's own sample is one of them), the others are copied down.
    const int nK = int(keep.size());
    sc.nextY.assign(size_t(nK) * n2, 0.f);
    sc.nextRgb.assign(size_t(nK) * n2, Rgb(0));
    sc.nextReal.assign(size_t(nK) * n2, 0);
    sc.nextFace.assign(size_t(nK) * n2, int8_t(-1));
    sc.nextLevel.assign(size_t(nK) * n2, int8_t(L + 1));
    for (int b = 0; b < nK; ++b) {
      const int a = keep[size_t(b)];
      const int l = sc.active[size_t(a)];
      for (int k = 0; k < n; ++k) {
        const int pi = k % K, pj = k / K;
        for (int d = 0; d < 4; ++d) {
          const int ci = 2 * pi + (d & 1), cj = 2 * pj + (d >> 1);
          const size_t dst = size_t(b) * n2 + size_t(cj) * K2 + size_t(ci);
          const size_t src = size_t(a) * n + size_t(k);
          if (!sc.split[src]) {
            sc.nextY[dst] = sc.cellY[src];
            sc.nextRgb[dst] = sc.cellRgb[src];
            sc.nextFace[dst] = sc.cellFace[src];
            sc.nextLevel[dst] = sc.cellLevel[src];
            continue;
          }
          sc.nextReal[dst] = 1;
          const Sample& cs = nxt[size_t(cj) * K2 + ci];
          if (cs.inPrev && cs.prevIndex == k) {
            sc.nextY[dst] = sc.cellY[src];
            sc.nextRgb[dst] = sc.cellRgb[src];
            sc.nextReal[dst] = sc.cellReal[src];
            sc.nextFace[dst] = sc.cellFace[src];
            continue;
          }
          if (!cs.ok) continue;
          sc.nextFace[dst] = faceOf(cs);
          uint8_t open;
          const Rgb c = contrib(cs, l, &open);
          sc.nextReal[dst] = uint8_t(1 + open);
          sc.nextRgb[dst] = c;
          sc.nextY[dst] = lum(c);
          ++evals;
          ++sc.samplesUsed[size_t(l)];
        }
      }
    }
    sc.next.clear();
    for (int a : keep) sc.next.push_back(sc.active[size_t(a)]);
    std::swap(sc.active, sc.next);
    std::swap(sc.cellY, sc.nextY);
    std::swap(sc.cellRgb, sc.nextRgb);
    std::swap(sc.cellReal, sc.nextReal);
    std::swap(sc.cellFace, sc.nextFace);
    std::swap(sc.cellLevel, sc.nextLevel);
  }

  if (m_gather) {
    // Indirect light, smooth over a texel away from edges: over the map's samples at edges.
    const std::vector<Sample>& set = edge ? map : sc.levels[0];
    const float w = 1.0f / float(set.size());
    // With the reciprocal scale the gathered row is summed apart, then scaled per light.
    thread_local std::vector<float> own;
    float* acc = out;
    if (m_gather->scaled()) {
      own.assign(size_t(nL) * 3, 0.f);
      acc = own.data();
    }
    for (const Sample& S : set)
      if (S.ok)
        m_gather->add(S.s.p, S.s.ng, S.s.n, S.s.prim, Vec3(wv), w, acc,
                      S.si >= 0 ? m_gather->cachedOcclusion(view, S.si) : -1.0f);
    if (acc != out) m_gather->addScaled(view, acc, out);
  }

  if (m_stats) {
    uint64_t byLevel[AdaptiveStats::kLevels] = {};
    double errSq = 0, valSq = 0;
    uint64_t used = 0;
    for (int l = 0; l < nL; ++l) {
      ++byLevel[sc.finalLevel[size_t(l)]];
      used += uint64_t(sc.samplesUsed[size_t(l)]);
      errSq += double(sc.err[size_t(l)]) * sc.err[size_t(l)];
      const double v = lum(Rgb(out[3 * l], out[3 * l + 1], out[3 * l + 2]));
      valSq += v * v;
    }
    for (int L = 0; L < AdaptiveStats::kLevels; ++L)
      if (byLevel[L]) m_stats->values[size_t(L)].fetch_add(byLevel[L], std::memory_order_relaxed);
    m_stats->texelViews.fetch_add(1, std::memory_order_relaxed);
    m_stats->samples.fetch_add(used, std::memory_order_relaxed);
    m_stats->evaluations.fetch_add(uint64_t(evals), std::memory_order_relaxed);
    if (edge) m_stats->edgeTexelViews.fetch_add(1, std::memory_order_relaxed);
    if (rays) m_stats->cameraRays.fetch_add(rays, std::memory_order_relaxed);
    m_stats->errorSq.fetch_add(errSq, std::memory_order_relaxed);
    m_stats->valueSq.fetch_add(valSq, std::memory_order_relaxed);
  }
  return evals;
}

}  // namespace btf
