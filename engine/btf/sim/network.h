// Global illumination inside the micro-geometry with the point network of §4.2.3 (fig. 4.7–4.10).
//
// Precompute (light-independent, once per scene):
//  * stratified points after Nehab & Shilane: the tile is voxelised, each triangle is split into
//    sub-triangles below an area threshold and each voxel keeps the sub-triangle centroid closest
//    to its centre; points closer than a minimum distance are pruned;
//  * per point, 256 stratified cosine-weighted directions around its normal: α(x) (eq. 4.19) is
//    the cosine-weighted fraction of them that hit geometry — the *occluded* fraction, because
//    light only arrives from other surfaces (the BTF's light is directional and the open sky is
//    black), so the occluded part of the hemisphere is exactly where indirect light comes from;
//  * links: among the occluded directions, up to `links` chosen at random (per point, without
//    replacement — a fixed pattern shared by all points biases every point the same way); each
//    link keeps its exact hit, used for the first-order light, and the nearest network point
//    facing the ray (the form-factor importance: same side, nearest), re-tested for
//    visibility, which carries the higher orders. Links cross tile sides (periodic images).
//
// Per light (reused by every view and texel): direct irradiance of each point from the light's
// shadow map (fig. 4.9), then P − 1 propagations along the links, L_ind_k of the expansion
// L = L_dir + Σ L_ind_k, with cosine-weighted link sampling giving the estimator
// E_ind(x) = α(x) · π / N · Σ_links L(y → x). Glossy points use the actual link directions at
// every bounce (a light-independent transfer table between incoming and outgoing links).
//
// Final gather: each direct hit of the hit maps takes the irradiance of its N1 nearest network
// points on the same side (distance-weighted), reflected by its own BRDF: kd/π · E for the
// diffuse term and, for glossy lobes, f(ω̄, ωo) · E with ω̄ the mean incident direction.
#pragma once
#include <btf/core/comm.h>
#include <btf/core/parallel.h>
#include <btf/core/progress.h>
#include <btf/directions/direction_set.h>
#include <btf/scene/material.h>
#include <btf/trace/periodic_tracer.h>

#include <functional>
#include <vector>

namespace btf {

struct NetworkSettings {
  int voxels = 64;           // voxels along the longer tile side (network density); 0 = auto
  float minDistance = 0.5f;  // pruning distance, in voxel sizes
  int alphaDirections = 256;
  int links = 16;  // links per network point
  int gather = 4;  // N1: network points per direct hit
  /// Rays per gathered hit measuring its own occluded fraction α(x): the network's irradiance
  /// is scaled by α(x)/α(point) (0: off). See NetworkGather.
  int gatherOcclusion = 16;
  uint64_t seed = 1;
};

struct NetworkPoint {
  Vec3 p;   // on the surface, inside [0, Lx) × [0, Ly)
  Vec3 ng;  // unit geometric normal (the triangle's orientation: the network is one-sided)
  Vec3 ns;  // unit shading normal on the same side
  uint32_t prim = 0;
  float alpha = 0;        // cosine-weighted occluded fraction of the hemisphere
  bool enclosed = false;  // inside a solid (most rays meet back faces): never used
  uint32_t linkBegin = 0, linkEnd = 0;
};

inline constexpr uint32_t kNoTarget = 0xffffffffu;

struct NetworkLink {
  uint32_t target = kNoTarget;  // network point standing for the hit (kNoTarget: none visible)
  Vec3 dir;                     // unit direction of the sampled ray
  // The exact hit of the ray: first-order light is evaluated there, so that shadow boundaries
  // are not moved by snapping; higher orders use the target's (smooth) indirect irradiance.
  Vec3 hitP;          // hit position (unwrapped: may lie in a neighbouring tile)
  Vec3 hitNg, hitNs;  // normals at the hit, facing back along the ray (two-sided surfaces)
  uint32_t hitPrim = 0;
};

class PointNetwork {
 public:
  void build(const PeriodicTracer& tracer, const NetworkSettings& settings,
             ProgressReporter* progress = nullptr, const CancelToken* cancel = nullptr);
  const std::vector<NetworkPoint>& points() const { return m_points; }
  const std::vector<NetworkLink>& links() const { return m_links; }
  const NetworkSettings& settings() const { return m_settings; }
  float voxelSize() const { return m_h; }
  double meanAlpha() const { return m_meanAlpha; }
  double maxAlpha() const { return m_maxAlpha; }
  double buildSeconds() const { return m_seconds; }
  uint64_t memoryBytes() const;

  /// Up to k nearest points to p whose normal agrees with n (cos > 0.3), within two voxel sizes
  /// (periodic distance); weights ∝ 1/(d + h/2), summing to 1. Returns how many were found.
  int nearest(const Vec3& p, const Vec3& n, int k, uint32_t* idx, float* w) const;

 private:
  void buildGrid();
  template <class F>
  void forNeighbours(const Vec3& p, int ring, F&& f) const;
  NetworkSettings m_settings;
  std::vector<NetworkPoint> m_points;
  std::vector<NetworkLink> m_links;
  double m_Lx = 1, m_Ly = 1;
  float m_h = 1, m_z0 = 0;
  int m_nx = 1, m_ny = 1, m_nz = 1;
  float m_cx = 1, m_cy = 1, m_cz = 1;
  std::vector<uint32_t> m_cellStart, m_cellPoints;
  double m_meanAlpha = 0, m_maxAlpha = 0, m_seconds = 0;
};

/// Light visibility of a surface point (p on triangle prim, geometric normal ng facing the
/// light) for light l of the set: the shadow-map test, shadow rays, or 1 without self-shadowing.
using LightVisibility = std::function<float(int l, const Vec3& p, const Vec3& ng, uint32_t prim)>;

/// How glossy receivers gather the indirect light: not at all (no glossy material), from the mean
/// incident direction of each network point (cheap, for wide lobes), or exactly along the links
/// of the nearest network point (per-link incoming radiance stored for every light).
enum class GlossyGather { None, MeanDirection, Links };
const char* glossyGatherName(GlossyGather g);

class NetworkLighting {
 public:
  /// Solves every light of `dirs` on the network: per point and light, the indirect irradiance
  /// of orders 1..P−1 (P = `bounces`) divided by cos θi (aBRDF units), and its mean incident
  /// direction when `directional` (needed by glossy receivers). lightLimit > 0 solves only the
  /// first lights (calibration of the estimate).
  ///
  /// A cluster job's share: with `parts` > 1 only the lights l ≡ `part` (mod parts) are solved
  /// (the others stay zero) and share() then gives every rank every light.
  void solve(const PointNetwork& net, const TileGeometry& geom,
             const std::vector<Material>& materials, const DirectionSet& dirs,
             const LightVisibility& visibility, int bounces, GlossyGather glossy,
             ProgressReporter* progress = nullptr, const CancelToken* cancel = nullptr,
             int lightLimit = -1, int part = 0, int parts = 1);
  /// After solve(…, comm.rank(), comm.size()) on every rank (a collective): every rank's lights
  /// copied to every other, in rounds of at most `roundBytes` per rank, so that each rank holds
  /// the arrays one process solving every light computes, to the bit. Returns the bytes this
  /// rank sent and received.
  uint64_t share(Comm& comm, uint64_t roundBytes = uint64_t(64) << 20);
  /// How many lights this process solved itself (all of them without a share).
  int solvedLights() const { return m_solvedLights; }
  /// The lights that `solve(…, part, parts)` solves, in order.
  static std::vector<int> lightsOfPart(int lights, int part, int parts);
  /// Before solve: add the orders past P − 1 in closed form. With the last two computed orders'
  /// totals over the network E_{P−2}, E_{P−1} (per light and channel), the ratio
  /// r = ΣE_{P−1} / ΣE_{P−2} (clamped to [0, 0.95]) continues the series: every point and link
  /// gains its last order × r / (1 − r) — the higher orders take the shape of the last one (the
  /// transport's dominant mode). Needs P ≥ 3; ignored otherwise.
  void setClosedFormTail(bool on) { m_closedFormTail = on; }
  int lights() const { return m_nL; }
  /// nL × 3 floats of point k: indirect irradiance / cos θi, per light and channel.
  const float* irradiance(uint32_t k) const { return &m_E[size_t(k) * size_t(m_nL) * 3]; }
  /// nL × 3 floats of point k: unit mean incident direction per light (world).
  const float* direction(uint32_t k) const { return &m_D[size_t(k) * size_t(m_nL) * 3]; }
  bool directional() const { return !m_D.empty(); }
  /// nL × 3 floats of link e: radiance arriving along it, every order, per light.
  const float* linkRadiance(uint32_t e) const { return &m_Lin[size_t(e) * size_t(m_nL) * 3]; }
  GlossyGather glossy() const { return m_glossy; }
  double solveSeconds() const { return m_seconds; }
  /// The light-independent part of solveSeconds (frames, glossy transfer tables).
  double setupSeconds() const { return m_setupSeconds; }
  static uint64_t memoryBytes(size_t points, size_t links, int lights, GlossyGather g) {
    const uint64_t row = uint64_t(lights) * 12;
    return uint64_t(points) * row * (g == GlossyGather::MeanDirection ? 2 : 1) +
           (g == GlossyGather::Links ? uint64_t(links) * row : 0);
  }

 private:
  int m_nL = 0, m_solvedLights = 0, m_parts = 1;
  std::vector<float> m_E, m_D, m_Lin;
  GlossyGather m_glossy = GlossyGather::None;
  double m_seconds = 0, m_setupSeconds = 0;
  bool m_closedFormTail = false;
};

/// The final gather of the indirect term for the direct hits of a view.
//
// The network is coarser than the relief it lights (a point per voxel; the noise terrain's bumps
// are a fraction of one), so a hit's nearest points may sit in a hollow while the hit is on a
// crest. E ≈ π α L̄ (occluded fraction × mean radiance of the occluders): with `tracer` and
// NetworkSettings::gatherOcclusion > 0, each hit measures its own α(x) with that many stratified
// cosine-weighted rays (seeded by its position: deterministic) and takes each point's
// irradiance times α(x)/α(point) (at most 4×), the occluders' radiance from the network.
class NetworkGather {
 public:
  NetworkGather(const PointNetwork& net, const NetworkLighting& light, const TileGeometry& geom,
                const std::vector<Material>& materials, const PeriodicTracer* tracer = nullptr)
      : m_tracer(tracer),
        m_alphaRays(tracer ? net.settings().gatherOcclusion : 0),
        m_net(net),
        m_light(light),
        m_geom(geom),
        m_materials(materials) {}
  /// Adds weight × the indirect aBRDF of every light to out[l * 3 + c] for the hit at p on
  /// triangle prim (normals ng, ns facing the viewer), seen from direction wo (world, unit).
  /// `alpha` ≥ 0: the hit's occluded fraction as occlusion(p, ng) measured it before (the
  /// same value; see occlusionCache).
  void add(const Vec3& p, const Vec3& ng, const Vec3& ns, uint32_t prim, const Vec3& wo,
           float weight, float* out, float alpha = -1) const;
  /// The cosine-weighted occluded fraction of the hemisphere around ng at p, from the
  /// settings' rays (deterministic per position); needs the tracer.
  float occlusion(const Vec3& p, const Vec3& ng) const;

  /// What add() would add for a set of hits, kept as weights: add(hit) summed over the hits
  /// equals Σ_points point[k] ⊙ E_k + Σ_links link[e] ⊙ R_e (+ `rest`, the mean-direction glossy
  /// term, which is not linear in E). Each weight is RGB (3 doubles); `touched*` list the
  /// points and links with a weight, so that a view's sums cost what its hits touch.
  struct Weights {
    std::vector<double> point, link, rest;
    std::vector<uint32_t> touchedPoints, touchedLinks;
    void reset(size_t points, size_t links, int lights);
  };
  /// The hit's weights (same arguments as add), accumulated into acc; the occluded fraction
  /// it measured in *alphaOut (−1: none).
  void addWeights(const Vec3& p, const Vec3& ng, const Vec3& ns, uint32_t prim, const Vec3& wo,
                  float weight, Weights& acc, float* alphaOut = nullptr) const;
  /// Rays per hit of the occluded fraction (0: not measured).
  int occlusionRays() const;
  /// The occluded fractions of the hit maps' samples, measured once (by the reciprocal gather's
  /// tile sums) and read back by add(): per (view, sample) the count of occluded rays, 255 where
  /// not measured. `samples` per view.
  void setOcclusionCache(std::vector<uint8_t> counts, int64_t samples) {
    m_alphaCache = std::move(counts);
    m_cacheSamples = samples;
  }
  /// The cached α of hit-map sample si seen from view, or −1.
  float cachedOcclusion(int view, int64_t si) const {
    if (m_alphaCache.empty()) return -1;
    const uint8_t c = m_alphaCache[size_t(view) * size_t(m_cacheSamples) + size_t(si)];
    return c == 255 ? -1.0f : float(c) / float(occlusionRays());
  }
  /// acc's sums per light: out[l * 3 + c] = Σ add(hit)[l * 3 + c] over acc's hits.
  void sumWeights(const Weights& acc, double* out) const;

  /// Per-(view, light, channel) factors on the gathered light (views × lights × 3, the
  /// directions of the lighting): empty for none. See reciprocal_gather.h.
  void setScale(std::vector<float> scale) { m_scale = std::move(scale); }
  bool scaled() const { return !m_scale.empty(); }
  /// out[k] += s[view][k] · g[k] over a row of lights (s = 1 without a scale).
  void addScaled(int view, const float* g, float* out) const;
  const PointNetwork& network() const { return m_net; }
  const NetworkLighting& lighting() const { return m_light; }

 private:
  // The hit's nearest points and their weights, with the hit's own occlusion when measured
  // (ax: α(x), or −1). Returns how many.
  int neighbours(const Vec3& p, const Vec3& ng, uint32_t* idx, float* w, float* ax,
                 float known) const;
  // The mean-direction glossy term of light l over the hit's neighbours (f(ω̄, ωo) · E).
  Rgb meanDirectionGlossy(const Material& m, const Frame& fr, const Vec3& woL,
                          const uint32_t* idx, const float* w, int n, int l, float weight) const;
  std::vector<float> m_scale;
  std::vector<uint8_t> m_alphaCache;
  int64_t m_cacheSamples = 0;
  const PeriodicTracer* m_tracer = nullptr;
  int m_alphaRays = 0;
  const PointNetwork& m_net;
  const NetworkLighting& m_light;
  const TileGeometry& m_geom;
  const std::vector<Material>& m_materials;
};

}  // namespace btf
