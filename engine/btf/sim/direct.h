// Direct illumination with self-shadowing, evaluated from the hit maps. Stored value is the
// apparent BRDF aBRDF = L_o / (E⊥ cos θi) = Σ_samples f_r(p) · (n·ωi) · V(p, ωi) / cos θi / K².
// Two visibility modes: the shadow-map test of fig. 4.9 (the light's own hit map, with a
// slope-scaled bias and 2×2 percentage-closer filtering, docs/conventions.md) and exact shadow
// rays through the periodic tracer.
#pragma once
#include <btf/directions/direction_set.h>
#include <btf/scene/material.h>
#include <btf/sim/hit_maps.h>

#include <string>
#include <vector>

namespace btf {

enum class ShadowMode { Map, Rays, None };  // None: no self-shadowing (the planner's choice)
ShadowMode parseShadowMode(const std::string& s);
const char* shadowModeName(ShadowMode m);

struct DirectSettings {
  ShadowMode shadows = ShadowMode::Map;
  float biasScale = 1.0f;  // multiplies the slope-scaled shadow-map bias
  /// Map mode: lights at θi ≥ this (degrees) use exact shadow rays, where the map's bias and
  /// filter footprint leak light (docs/conventions.md); 90 = the map for every light.
  double raysFromThetaDeg = 90;
};

class DirectIllumination {
 public:
  DirectIllumination(const PeriodicTracer& tracer, const std::vector<Material>& materials,
                     const DirectionSet& dirs, const HitMaps& maps, DirectSettings settings);

  /// aBRDF of texel (i, j) seen from direction `view`, for every light of the set:
  /// out[l * 3 + c], l in [0, nL). Returns the number of (sample, light) BRDF evaluations made.
  int64_t evalTexelView(int i, int j, int view, float* out) const;
  /// The same for `count` texels (ti[k], tj[k]) seen from one view, out[k] the k-th texel's row:
  /// lights outer, samples inner, so one light's shadow-map taps for neighbouring texels share
  /// cache lines (at 64² × 16×32 the maps are 16 MiB and each tap otherwise misses L2). Every
  /// value is bit-identical to evalTexelView's.
  int64_t evalTexelsView(const int* ti, const int* tj, int count, int view,
                         float* const* out) const;
  /// Texels per block that evalTexelsView is meant for.
  static constexpr int kBlockTexels = 16;
  /// Same, for an arbitrary light direction (unit, above the plane) — shadow rays only when the
  /// light is not in the set, since only the set's directions have shadow maps.
  Rgb evalTexelViewLight(int i, int j, int view, const DVec3& light) const;

  /// Light visibility in [0, 1] of point p (on triangle prim, geometric normal ng facing the
  /// light) for light l of the set, in the configured mode.
  float lightVisibility(int l, const Vec3& p, const Vec3& ng, uint32_t prim) const;
  const DirectSettings& settings() const { return m_settings; }
  /// Triangles whose samples the kernels leave out (mask[prim] ≠ 0): the faces that exact
  /// visibility shades by area (sim/exact_direct.h). Empty: none.
  void skipTriangles(std::vector<uint8_t> mask) { m_skip = std::move(mask); }

  /// A shaded point of the surface: the hit of a camera ray, ready to be lit by any light.
  struct Surface {
    Vec3 p, ng, n, wo;  // hit point, geometric and shading normals, view in the local frame
    Vec3 wv;            // the view direction in world space
    float ngXY = 0;     // |ng's projection on the plane|: the shadow map's slope bias
    Frame frame;
    DVec3 origin;  // p offset along ng: shadow rays start here
    const Material* mat = nullptr;
    uint32_t prim = kNoHit;
    uint32_t material = 0;
    bool lambert = false;
  };
  /// The surface seen by the camera ray of plane point `planePoint` for view `wv` whose hit is
  /// (prim, bu, bv) at signed distance `depth` along ωv. False when the ray misses or the
  /// triangle is degenerate (the sample then contributes nothing).
  bool surface(const DVec3& planePoint, const DVec3& wv, uint32_t prim, float bu, float bv,
               float depth, Surface* s) const;
  /// The aBRDF contribution of one surface sample for light l of the set: f · (n·ωi) · V / cos θi
  /// (zero when the light is below the surface). `exactShadow`: a shadow ray even in map mode.
  Rgb contribution(const Surface& s, int l, bool exactShadow = false) const;
  /// The same without the visibility: f · (n·ωi) / cos θi, zero when the light is below the
  /// surface. It depends on the surface only through its material, normals and view: samples
  /// of one flat face share it.
  Rgb unshadowed(const Surface& s, int l) const;
  /// Light l's visibility in [0, 1] at a surface that faces it (unshadowed ≠ 0), as
  /// `contribution` computes it. With exactShadow in map mode, *mapDecided (when given) says
  /// whether the map's 3 × 3 taps around the point agreed (false: an exact ray decided).
  float visibility(const Surface& s, int l, bool exactShadow = false,
                   bool* mapDecided = nullptr) const;
  /// Whether light l's visibility is an exact shadow ray (rays mode, or a grazing light).
  bool exactRays(int l) const {
    return m_settings.shadows == ShadowMode::Rays ||
           (m_settings.shadows == ShadowMode::Map && m_lights[size_t(l)].rays);
  }

  /// Shadow-map visibility in [0, 1] of point p (on triangle `prim`, geometric normal ng) for
  /// light `l` of the set.
  float shadowMapVisibility(int l, const Vec3& p, const Vec3& ng, uint32_t prim) const;

 private:
  struct LightInfo {
    Vec3 w;
    float invCos;          // 1 / cos θi, for the aBRDF division
    float slopeX, slopeY;  // ωx/ωz, ωy/ωz: projection onto the reference plane
    bool rays;             // map mode, grazing light: exact shadow rays instead
  };
  /// Shadow-map visibility with the per-sample and per-pair terms already known: cn = ng·ωi > 0,
  /// ngXY = |ng_xy|. With `decided`: 0 or 1 where the 3 × 3 taps around p agree (*decided
  /// true), else *decided false (the caller traces a ray).
  float mapVisibility(int l, const Vec3& p, float cn, float ngXY, uint32_t prim,
                      bool* decided = nullptr) const;
  /// f_r(ωi = light l, ωo = wv) at shading normal n, given cosN = n·ωi > 0 and won = n·ωv > 0.
  /// Blinn-Phong in world space (n·h = cosN + won, |h|² = 2 + 2 ωi·ωv: no frame, no sqrt of h);
  /// the other models through the local frame.
  Rgb brdf(const Material& mat, const Frame& frame, const Vec3& wo, const Vec3& wv, float cosN,
           float won, int l) const;

  const PeriodicTracer& m_tracer;
  const TileGeometry& m_geom;
  const std::vector<Material>& m_materials;
  const DirectionSet& m_dirs;
  const HitMaps& m_maps;
  DirectSettings m_settings;
  std::vector<LightInfo> m_lights;
  std::vector<uint8_t> m_skip;
  float m_cell;  // sample spacing on the plane
  float m_toSampleX, m_toSampleY, m_invSu, m_invSv;
};

}  // namespace btf
