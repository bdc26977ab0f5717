#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/sim/adaptive.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <vector>

namespace btf {

int adaptiveLevel(int K) {
  for (int L = 0; L < AdaptiveStats::kLevels; ++L)
    if ((2 << L) == K) return L;
  return -1;
}

double AdaptiveStats::meanSamples() const {
  double n = 0;
  for (const auto& v : values) n += double(v.load());
  return n > 0 ? double(samples.load()) / n : 0;
}

double AdaptiveStats::estimatedRelativeError() const {
  const double v = valueSq.load();
  return v > 0 ? std::sqrt(errorSq.load() / v) : 0;
}

std::string AdaptiveStats::histogramText() const {
  double n = 0;
  for (const auto& v : values) n += double(v.load());
  std::string s;
  for (int L = 0; L < kLevels; ++L) {
    const double c = double(values[size_t(L)].load());
    if (c == 0) continue;
    char b[64];
    std::snprintf(b, sizeof b, "%s%d×%d %.1f %%", s.empty() ? "" : ", ", 2 << L, 2 << L,
                  100.0 * c / std::max(1.0, n));
    s += b;
  }
  return s;
}

std::vector<double> AdaptiveStats::toVector() const {
  std::vector<double> v;
  for (const auto& x : values) v.push_back(double(x.load()));
  for (const auto* x : {&samples, &texelViews, &edgeTexelViews, &cameraRays})
    v.push_back(double(x->load()));
  v.push_back(errorSq.load());
  v.push_back(valueSq.load());
  return v;
}

void AdaptiveStats::assign(const std::vector<double>& v) {
  BTF_CHECK(v.size() == size_t(kLevels) + 6);
  size_t i = 0;
  for (auto& x : values) x = uint64_t(v[i++]);
  for (auto* x : {&samples, &texelViews, &edgeTexelViews, &cameraRays}) *x = uint64_t(v[i++]);
  errorSq = v[i++];
  valueSq = v[i++];
}

std::string AdaptiveStats::json() const {
  nlohmann::ordered_json j;
  nlohmann::ordered_json h = nlohmann::ordered_json::object();
  for (int L = 0; L < kLevels; ++L)
    if (values[size_t(L)].load())
      h[std::to_string(2 << L) + "x" + std::to_string(2 << L)] = values[size_t(L)].load();
  j["values_by_samples"] = h;
  j["mean_samples_per_value"] = meanSamples();
  j["texel_views"] = texelViews.load();
  j["edge_texel_views"] = edgeTexelViews.load();
  j["camera_rays"] = cameraRays.load();
  j["estimated_relative_error"] = estimatedRelativeError();
  return j.dump();
}

namespace {

struct Sample {
  DVec3 pos;     // on the reference plane
  float lx = 0;  // position inside the texel, in [0, 1)
  float ly = 0;
  bool ok = false;      // the camera ray hit a shadeable surface
  bool inPrev = false;  // already part of the previous level (its contributions are summed)
  int prevIndex = -1;   // its index in the previous level's array
  DirectIllumination::Surface s;
};

struct Scratch {
  std::vector<Sample> levels[AdaptiveStats::kLevels];
  // Per active light (slot) and cell of the current level: luminance, RGB, own sample or not.
  std::vector<float> cellY, nextY;
  std::vector<Rgb> cellRgb, nextRgb;
  std::vector<uint8_t> cellReal, nextReal, split, made, kept, hot;
  std::vector<int> samplesUsed, finalLevel, keep;
  std::vector<float> err;        // per light: error estimate of its last level
  std::vector<uint8_t> flagged;  // per light: the quadrants whose footprint holds a shadow edge
  std::vector<int> active, next;
};

inline float lum(const Rgb& c) {
  return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
}

}  // namespace

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
  }
  // A quarter of the brightest diffuse aBRDF of the scene's materials.
  float brightest = 0;
  for (const Material& m : materials)
    brightest = std::max(brightest, lum(m.kdOverPi) + lum(m.ks) * (1.0f / 3.14159265f));
  m_floor = 0.25f * std::max(brightest, 1e-3f);
}

int64_t AdaptiveTexelSampler::eval(int i, int j, int view, float* out) const {
  thread_local Scratch sc;
  const int nL = m_dirs.size();
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
      S.ok = m_direct.surface(S.pos, wv, m_maps.prim(view, si), m_maps.bu(view, si),
                              m_maps.bv(view, si), m_maps.depth(view, si), &S.s);
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
  // Edge samples of direction d's table in the texel-local rectangle [x0, x1] × [y0, y1] swept
  // along −ω over heights [zlo, zhi] (slopes sx, sy in samples per unit height), widened by one
  // sample.
  auto edgesIn = [&](int d, float x0, float x1, float y0, float y1, float sx, float sy, float zlo,
                     float zhi) {
    if (!m_maps.hasEdgeTables()) return false;
    const float a0 = (float(i) + x0) * float(Km) - std::max(zlo * sx, zhi * sx) - 1.0f;
    const float a1 = (float(i) + x1) * float(Km) - std::min(zlo * sx, zhi * sx) + 1.0f;
    const float b0 = (float(j) + y0) * float(Km) - std::max(zlo * sy, zhi * sy) - 1.0f;
    const float b1 = (float(j) + y1) * float(Km) - std::min(zlo * sy, zhi * sy) + 1.0f;
    return m_maps.edgeCount(d, int(std::floor(a0)), int(std::ceil(a1)), int(std::floor(b0)),
                            int(std::ceil(b1))) > 0;
  };
  // A receiver seen through plane point x at height z lies at x + z·sv (sv: the view's slope,
  // ω.xy / ω.z); light l's map holds it at x + z·(sv − sl). In map samples per unit height:
  const float vsx = m_slopeX[size_t(view)], vsy = m_slopeY[size_t(view)];
  auto lightSlopeX = [&](int l) { return (m_slopeX[size_t(l)] - vsx) * m_toSampleX; };
  auto lightSlopeY = [&](int l) { return (m_slopeY[size_t(l)] - vsy) * m_toSampleY; };
  sc.flagged.assign(size_t(nL), 0);
  float qlo[4], qhi[4];
  bool qok[4];
  for (int q = 0; q < 4; ++q) qok[q] = zRange(2, q & 1, q >> 1, &qlo[q], &qhi[q]);
  float tlo = INFINITY, thi = -INFINITY;
  for (int q = 0; q < 4; ++q)
    if (qok[q]) tlo = std::min(tlo, qlo[q]), thi = std::max(thi, qhi[q]);
  for (int l = 0; l < nL && m_shadowEdges && okCount; ++l) {
    const float sx = lightSlopeX(l), sy = lightSlopeY(l);
    // The whole texel first: most lights have no edge near it.
    if (!edgesIn(l, 0.0f, 1.0f, 0.0f, 1.0f, sx, sy, tlo, thi)) continue;
    for (int q = 0; q < 4; ++q)
      if (qok[q] && edgesIn(l, 0.5f * float(q & 1), 0.5f * float((q & 1) + 1), 0.5f * float(q >> 1),
                            0.5f * float((q >> 1) + 1), sx, sy, qlo[q], qhi[q]))
        sc.flagged[size_t(l)] |= uint8_t(1u << q);
  }

  // A sample's contribution for light l (flagged lights: exact shadow rays where the map's taps
  // disagree).
  auto contrib = [&](const Sample& S, int l) -> Rgb {
    return m_direct.contribution(S.s, l, sc.flagged[size_t(l)] != 0);
  };

  // Every light starts from level 0. Per light and level, a K×K array of cells: the luminance
  // and RGB of the cell's own sample ("real" cells) or, where a coarser cell was not split, of
  // that cell's sample (a stratum of the coarser level). The estimate is the mean over cells.
  sc.cellY.assign(size_t(nL) * 4, 0.f);
  sc.cellRgb.assign(size_t(nL) * 4, Rgb(0));
  sc.cellReal.assign(size_t(nL) * 4, 1);
  sc.samplesUsed.assign(size_t(nL), 4);
  sc.finalLevel.assign(size_t(nL), 0);
  int64_t evals = 0;
  // Light by light: one light's shadow-map taps for the four samples share cache lines.
  for (int q = 0; q < 4; ++q) evals += sc.levels[0][size_t(q)].ok ? nL : 0;
  for (int l = 0; l < nL; ++l)
    for (int q = 0; q < 4; ++q) {
      const Sample& S = sc.levels[0][size_t(q)];
      if (!S.ok) continue;
      const Rgb c = contrib(S, l);
      sc.cellRgb[size_t(l) * 4 + size_t(q)] = c;
      sc.cellY[size_t(l) * 4 + size_t(q)] = lum(c);
    }
  const float tol = m_settings.tolerance;
  auto threshold = [&](float mean) { return tol * std::max(std::abs(mean), m_floor); };
  sc.active.resize(size_t(nL));
  for (int l = 0; l < nL; ++l) sc.active[size_t(l)] = l;
  sc.err.assign(size_t(nL), 0.f);

  // Level by level: each active light splits the cells that need it; the others stop.
  uint64_t rays = 0;
  auto finishLight = [&](int l, const Rgb* cells, int n) {
    Rgb sum(0);
    for (int k = 0; k < n; ++k) sum += cells[k];
    sum /= float(n);
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
          if (!real[k]) continue;
          bool s = false;
          if (byValue)
            s = sc.hot[size_t(k)] || (c > 0 && sc.hot[size_t(k - 1)]) ||
                (c + 1 < K && sc.hot[size_t(k + 1)]) || (r > 0 && sc.hot[size_t(k - K)]) ||
                (r + 1 < K && sc.hot[size_t(k + K)]);
          // The cell's quadrant (level 0: the cell itself).
          const unsigned quadrant = 1u << ((c * 2 / K) + 2 * (r * 2 / K));
          if (!s && byEdges && L == 0) s = edge || (flags & quadrant);
          if (!s && byEdges && L > 0) {
            const float x0 = c * inv, x1 = (c + 1) * inv, y0 = r * inv, y1 = (r + 1) * inv;
            float zl, zh;
            s = (m_settings.edgeCells && edge && byValue &&
                 edgesIn(view, x0, x1, y0, y1, 0, 0, 0, 0)) ||
                ((flags & quadrant) && zRange(K, c, r, &zl, &zh) &&
                 edgesIn(l, x0, x1, y0, y1, lightSlopeX(l), lightSlopeY(l), zl, zh));
          }
          sp[k] = s;
          any = any || s;
        }
      if (any) keep.push_back(a), sc.kept[size_t(a)] = 1;
    }
    // The lights that stop here keep this level's estimate.
    for (int a = 0; a < nA; ++a)
      if (!sc.kept[size_t(a)]) finishLight(sc.active[size_t(a)], &sc.cellRgb[size_t(a) * n], n);
    if (keep.empty()) break;

    // 2. The next level's samples where some light splits a cell (fresh camera rays beyond
    // the map's level, traced once and shared by every light).
    const int K2 = 2 * K, n2 = K2 * K2;
    std::vector<Sample>& nxt = sc.levels[L + 1];
    if (L + 1 > m_mapLevel) {
      nxt.resize(size_t(n2));
      sc.made.assign(size_t(n), 0);
      for (int a : keep)
        for (int k = 0; k < n; ++k) sc.made[size_t(k)] |= sc.split[size_t(a) * n + k];
      const std::vector<Sample>& par = sc.levels[L];
      for (int k = 0; k < n; ++k) {
        if (!sc.made[size_t(k)]) continue;
        const int pi = k % K, pj = k / K;
        const Sample& ps = par[size_t(k)];
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
          cs.ok = hit.hit() && m_direct.surface(cs.pos, wv, hit.prim, hit.u, hit.v, depth, &cs.s);
        }
      }
    }

    // 3. Each light that splits moves to the next level: split cells get their four children's
    // samples (the parent's own sample is one of them), the others are copied down.
    const int nK = int(keep.size());
    sc.nextY.assign(size_t(nK) * n2, 0.f);
    sc.nextRgb.assign(size_t(nK) * n2, Rgb(0));
    sc.nextReal.assign(size_t(nK) * n2, 0);
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
            continue;
          }
          sc.nextReal[dst] = 1;
          const Sample& cs = nxt[size_t(cj) * K2 + ci];
          if (cs.inPrev && cs.prevIndex == k) {
            sc.nextY[dst] = sc.cellY[src];
            sc.nextRgb[dst] = sc.cellRgb[src];
            continue;
          }
          if (!cs.ok) continue;
          const Rgb c = contrib(cs, l);
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
  }

  if (m_gather) {
    // Indirect light, smooth over a texel away from edges: over the map's samples at edges.
    const std::vector<Sample>& set = edge ? map : sc.levels[0];
    const float w = 1.0f / float(set.size());
    for (const Sample& S : set)
      if (S.ok) m_gather->add(S.s.p, S.s.ng, S.s.n, S.s.prim, Vec3(wv), w, out);
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
    if (edge) m_stats->edgeTexelViews.fetch_add(1, std::memory_order_relaxed);
    if (rays) m_stats->cameraRays.fetch_add(rays, std::memory_order_relaxed);
    m_stats->errorSq.fetch_add(errSq, std::memory_order_relaxed);
    m_stats->valueSq.fetch_add(valSq, std::memory_order_relaxed);
  }
  return evals;
}

}  // namespace btf
