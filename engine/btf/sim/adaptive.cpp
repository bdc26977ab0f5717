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
  double n = 0, s = 0;
  for (int L = 0; L < kLevels; ++L) {
    const double k = double(2 << L);
    n += double(values[size_t(L)].load());
    s += double(values[size_t(L)].load()) * k * k;
  }
  return n > 0 ? s / n : 0;
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
  std::vector<Rgb> acc;    // per light: Σ contributions over the samples of its level
  std::vector<int> count;  // per light: samples of its level
  std::vector<float> err;             // per light: error estimate of its last level
  std::vector<float> yPrev, yCur;     // [active slot][stratum]: luminance contributions
  std::vector<int> slot;              // per light: its slot in yPrev
  std::vector<uint8_t> flagged;       // per light: a shadow edge lies in its footprint
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
      const uint64_t c =
          hashKeys(g.seed, uint64_t(i) * 2 + uint64_t(qa), uint64_t(j) * 2 + uint64_t(qb),
                   0x1e7e10) &
          3;
      const size_t k = size_t(2 * qb + int(c >> 1)) * 4 + size_t(2 * qa + int(c & 1));
      l0[size_t(q)] = map[k];
      l0[size_t(q)].inPrev = false;
      map[k].inPrev = true;
      map[k].prevIndex = q;  // level 0 is stored in quadrant order, a 2×2 stratum grid
    }
  }

  // Does the texel straddle an edge? Hit and miss, two materials, a crease or a depth step
  // among the map's samples.
  bool edge = false, anyMiss = false;
  const Sample* first = nullptr;
  for (const Sample& S : map) {
    if (!S.ok) {
      anyMiss = true;
      continue;
    }
    if (!first) {
      first = &S;
      continue;
    }
    const auto& A = first->s;
    const auto& B = S.s;
    if (A.material != B.material || glm::dot(A.n, B.n) < 0.9f ||
        std::abs(glm::dot(A.ng, B.p - A.p)) > 0.1f * float(m_texelSize))
      edge = true;
  }
  edge = edge || (anyMiss && first);
  // An edge just outside the map's samples (a sliver they all missed): the view's edge table
  // over the texel and a guard band of one map sample.
  if (!edge && m_maps.hasEdgeTables())
    edge = m_maps.edgeCount(view, i * Km - 1, (i + 1) * Km + 1, j * Km - 1, (j + 1) * Km + 1) > 0;

  // Shadow boundaries: the light's own edge table over the footprint of the receivers seen in
  // this texel, projected along ωi onto the plane (the texel swept over its receivers' heights,
  // widened by a map sample). A light whose footprint holds an edge is refined as if an edge of
  // its full value crossed the texel unseen: error ≥ 0.4 · value · K^-1.5; and in map mode its
  // visibility comes from exact shadow rays (the map places a boundary within ±½ map sample).
  sc.flagged.assign(size_t(nL), 0);
  int okCount = 0;
  for (const Sample& S : sc.levels[0]) okCount += S.ok;
  float zlo = INFINITY, zhi = -INFINITY;
  for (const Sample& S : map)
    if (S.ok) zlo = std::min(zlo, S.s.p.z), zhi = std::max(zhi, S.s.p.z);
  for (int l = 0; l < nL && m_shadowEdges && okCount; ++l) {
    // The texel's rectangle, swept along −ωi over the heights of its receivers, plus one sample.
    const float sx = m_slopeX[size_t(l)] * m_toSampleX, sy = m_slopeY[size_t(l)] * m_toSampleY;
    const float a0 = float(i * Km) - std::max(zlo * sx, zhi * sx) - 1.0f;
    const float a1 = float((i + 1) * Km) - std::min(zlo * sx, zhi * sx) + 1.0f;
    const float b0 = float(j * Km) - std::max(zlo * sy, zhi * sy) - 1.0f;
    const float b1 = float((j + 1) * Km) - std::min(zlo * sy, zhi * sy) + 1.0f;
    sc.flagged[size_t(l)] = m_maps.edgeCount(l, int(std::floor(a0)), int(std::ceil(a1)),
                                             int(std::floor(b0)), int(std::ceil(b1))) > 0;
  }
  // Level 0 for every light; y holds each active light's per-sample luminance contributions.
  sc.acc.assign(size_t(nL), Rgb(0));
  sc.count.assign(size_t(nL), 4);
  sc.err.assign(size_t(nL), 0.f);
  sc.active.resize(size_t(nL));
  for (int l = 0; l < nL; ++l) sc.active[size_t(l)] = l;
  sc.yPrev.assign(size_t(nL) * 4, 0.f);
  sc.slot.assign(size_t(nL), -1);
  int64_t evals = 0;
  for (int q = 0; q < 4; ++q) {
    const Sample& S = sc.levels[0][size_t(q)];
    if (!S.ok) continue;
    for (int l = 0; l < nL; ++l) {
      const Rgb c = m_direct.contribution(S.s, l, sc.flagged[size_t(l)] != 0);
      sc.acc[size_t(l)] += c;
      sc.yPrev[size_t(l) * 4 + size_t(q)] = lum(c);
    }
    evals += nL;
  }
  // Values below the floor count by absolute error (a light's decision depends on nothing but
  // its own samples: a one-pair preview refines exactly as the full run).
  const float tol = m_settings.tolerance;
  auto threshold = [&](float mean) { return tol * std::max(std::abs(mean), m_floor); };
  auto unseenEdge = [](float mean, int K) {
    return 0.4f * std::abs(mean) / (float(K) * std::sqrt(float(K)));
  };
  // Error of a level's mean from the differences between neighbouring strata (across block
  // boundaries too, so that an edge lying on a stratum boundary is not missed): a step of height
  // c crossing a K×K set differs in ~K neighbour pairs and leaves an error ~0.4 c K^-1.5 — what
  // 0.5 · sqrt(Σ Δ²) / K² gives; a smooth gradient gives ~g / K², the jittered estimate's order.
  auto strataError = [](const float* y, int K) {
    double sum = 0;
    for (int r = 0; r < K; ++r)
      for (int c = 0; c < K; ++c) {
        const float v = y[size_t(r) * K + c];
        if (c + 1 < K) sum += double(v - y[size_t(r) * K + c + 1]) * (v - y[size_t(r) * K + c + 1]);
        if (r + 1 < K) sum += double(v - y[size_t(r + 1) * K + c]) * (v - y[size_t(r + 1) * K + c]);
      }
    return float(0.5 * std::sqrt(sum) / (double(K) * K));
  };
  // Level-0 samples are stored in quadrant order: the same as a 2×2 stratum grid.
  sc.next.clear();
  for (int l = 0; l < nL; ++l) {
    float e = strataError(&sc.yPrev[size_t(l) * 4], 2);
    const float mean = lum(sc.acc[size_t(l)]) * 0.25f;
    if (sc.flagged[size_t(l)]) e = std::max(e, unseenEdge(mean, 2));
    sc.err[size_t(l)] = e;
    sc.slot[size_t(l)] = l;
    if (m_maxLevel >= 1 && (edge || e > threshold(mean))) sc.next.push_back(l);
  }
  std::swap(sc.active, sc.next);
  int prevN = 4;

  // Finer levels while a light's estimate is still uncertain.
  uint64_t rays = 0;
  for (int L = 1; L <= m_maxLevel && !sc.active.empty(); ++L) {
    const int K = 2 << L;
    std::vector<Sample>& cur = sc.levels[L];
    if (L > m_mapLevel) {
      // Split every stratum of level L − 1 in four: the child holding the parent's sample keeps
      // it, the three others get fresh jittered samples (and camera rays).
      const std::vector<Sample>& par = sc.levels[L - 1];
      const int Kp = K / 2;
      cur.resize(size_t(K) * K);
      for (int pj = 0; pj < Kp; ++pj)
        for (int pi = 0; pi < Kp; ++pi) {
          const Sample& ps = par[size_t(pj) * Kp + pi];
          const int cx = std::clamp(int(ps.lx * float(K)), 2 * pi, 2 * pi + 1);
          const int cy = std::clamp(int(ps.ly * float(K)), 2 * pj, 2 * pj + 1);
          for (int d = 0; d < 4; ++d) {
            const int ci = 2 * pi + (d & 1), cj = 2 * pj + (d >> 1);
            Sample& cs = cur[size_t(cj) * K + ci];
            if (ci == cx && cj == cy) {
              cs = ps;
              cs.inPrev = true;
              cs.prevIndex = pj * Kp + pi;
              continue;
            }
            const uint64_t h = hashKeys(g.seed ^ 0xada97a1e5ull, uint64_t(i) * K + uint64_t(ci),
                                        uint64_t(j) * K + uint64_t(cj), uint64_t(L));
            cs.lx = (float(ci) + uniformFloat(h)) / float(K);
            cs.ly = (float(cj) + uniformFloat(mix64(h))) / float(K);
            cs.pos = DVec3((i + double(cs.lx)) * g.Lx / g.nu, (j + double(cs.ly)) * g.Ly / g.nv,
                           0.0);
            float depth;
            const RayHit hit = traceSampleRay(m_tracer, cs.pos, wv, &depth);
            ++rays;
            cs.inPrev = false;
            cs.prevIndex = -1;
            cs.ok = hit.hit() && m_direct.surface(cs.pos, wv, hit.prim, hit.u, hit.v, depth, &cs.s);
          }
        }
    }
    const int n = K * K;
    const int nA = int(sc.active.size());
    sc.yCur.assign(size_t(nA) * n, 0.f);
    for (int k = 0; k < n; ++k) {
      const Sample& S = cur[size_t(k)];
      if (S.inPrev) {
        for (int a = 0; a < nA; ++a)
          sc.yCur[size_t(a) * n + k] =
              sc.yPrev[size_t(sc.slot[size_t(sc.active[size_t(a)])]) * prevN + S.prevIndex];
        continue;
      }
      if (!S.ok) continue;
      for (int a = 0; a < nA; ++a) {
        const int l = sc.active[size_t(a)];
        const Rgb c = m_direct.contribution(S.s, l, sc.flagged[size_t(l)] != 0);
        sc.acc[size_t(l)] += c;
        sc.yCur[size_t(a) * n + k] = lum(c);
      }
      evals += nA;
    }
    sc.next.clear();
    for (int a = 0; a < nA; ++a) {
      const int l = sc.active[size_t(a)];
      sc.count[size_t(l)] = n;
      sc.slot[size_t(l)] = a;
      const float mean = lum(sc.acc[size_t(l)]) / float(n);
      float e = strataError(&sc.yCur[size_t(a) * n], K);
      if (sc.flagged[size_t(l)]) e = std::max(e, unseenEdge(mean, K));
      sc.err[size_t(l)] = e;
      if (L < m_maxLevel && e > threshold(mean))
        sc.next.push_back(l);
    }
    std::swap(sc.active, sc.next);
    std::swap(sc.yPrev, sc.yCur);
    prevN = n;
  }

  for (int l = 0; l < nL; ++l) {
    const float w = 1.0f / float(sc.count[size_t(l)]);
    out[3 * l] = sc.acc[size_t(l)].x * w;
    out[3 * l + 1] = sc.acc[size_t(l)].y * w;
    out[3 * l + 2] = sc.acc[size_t(l)].z * w;
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
    for (int l = 0; l < nL; ++l) {
      const int L = adaptiveLevel(int(std::lround(std::sqrt(double(sc.count[size_t(l)])))));
      ++byLevel[std::max(0, L)];
      errSq += double(sc.err[size_t(l)]) * sc.err[size_t(l)];
      const double v = lum(Rgb(out[3 * l], out[3 * l + 1], out[3 * l + 2]));
      valSq += v * v;
    }
    for (int L = 0; L < AdaptiveStats::kLevels; ++L)
      if (byLevel[L]) m_stats->values[size_t(L)].fetch_add(byLevel[L], std::memory_order_relaxed);
    m_stats->texelViews.fetch_add(1, std::memory_order_relaxed);
    if (edge) m_stats->edgeTexelViews.fetch_add(1, std::memory_order_relaxed);
    if (rays) m_stats->cameraRays.fetch_add(rays, std::memory_order_relaxed);
    m_stats->errorSq.fetch_add(errSq, std::memory_order_relaxed);
    m_stats->valueSq.fetch_add(valSq, std::memory_order_relaxed);
  }
  return evals;
}

}  // namespace btf
