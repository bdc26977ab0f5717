#include <btf/core/error.h>
#include <btf/sim/direct.h>
#include <btf/sim/shading.h>

#include <algorithm>
#include <cmath>

namespace btf {

ShadowMode parseShadowMode(const std::string& s) {
  if (s == "map") return ShadowMode::Map;
  if (s == "rays") return ShadowMode::Rays;
  if (s == "none") return ShadowMode::None;
  throw Error("unknown shadow mode '" + s + "' (expected map or rays)");
}
const char* shadowModeName(ShadowMode m) {
  return m == ShadowMode::Map ? "map" : m == ShadowMode::Rays ? "rays" : "none";
}

float DirectIllumination::lightVisibility(int l, const Vec3& p, const Vec3& ng,
                                          uint32_t prim) const {
  switch (m_settings.shadows) {
    case ShadowMode::Map:
      if (!m_lights[size_t(l)].rays) return shadowMapVisibility(l, p, ng, prim);
      [[fallthrough]];
    case ShadowMode::Rays:
      return m_tracer.occluded(DVec3(p) + m_tracer.epsilon() * DVec3(ng),
                               DVec3(m_lights[size_t(l)].w))
                 ? 0.0f
                 : 1.0f;
    case ShadowMode::None:
      return 1.0f;
  }
  return 1.0f;
}

DirectIllumination::DirectIllumination(const PeriodicTracer& tracer,
                                       const std::vector<Material>& materials,
                                       const DirectionSet& dirs, const HitMaps& maps,
                                       DirectSettings settings)
    : m_tracer(tracer),
      m_geom(tracer.geometry()),
      m_materials(materials),
      m_dirs(dirs),
      m_maps(maps),
      m_settings(settings) {
  for (const auto& d : dirs.dirs()) {
    const double c = std::max(d.w.z, 1e-7);
    const bool rays =
        settings.shadows == ShadowMode::Map && rad2deg(d.theta) >= settings.raysFromThetaDeg - 1e-9;
    m_lights.push_back({Vec3(d.w), float(1.0 / c), float(d.w.x / c), float(d.w.y / c), rays});
  }
  const SampleGrid& g = maps.grid();
  m_cell = float(std::max(g.Lx / g.su(), g.Ly / g.sv()));
  m_toSampleX = float(g.su() / g.Lx);
  m_toSampleY = float(g.sv() / g.Ly);
  m_invSu = 1.0f / float(g.su());
  m_invSv = 1.0f / float(g.sv());
}

float DirectIllumination::shadowMapVisibility(int l, const Vec3& p, const Vec3& ng,
                                              uint32_t prim) const {
  const LightInfo& L = m_lights[size_t(l)];
  const SampleGrid& g = m_maps.grid();
  // Project p along ωi onto the plane: q = p − (p.z / cos θi) ωi; r is p's distance along ωi.
  // Float is enough: even at θ = 89.9° the offset spans < 10⁴ samples (ulp < 10⁻³ sample).
  const float r = p.z * L.invCos;
  const int su = g.su(), sv = g.sv();
  float fx = (p.x - p.z * L.slopeX) * m_toSampleX - 0.5f;
  float fy = (p.y - p.z * L.slopeY) * m_toSampleY - 0.5f;
  fx -= std::floor(fx * m_invSu) * float(su);
  fy -= std::floor(fy * m_invSv) * float(sv);
  int i0 = int(fx), j0 = int(fy);
  const float tx = fx - float(i0), ty = fy - float(j0);
  i0 = std::min(std::max(i0, 0), su - 1);
  j0 = std::min(std::max(j0, 0), sv - 1);
  const int i1 = i0 + 1 == su ? 0 : i0 + 1, j1 = j0 + 1 == sv ? 0 : j0 + 1;
  // Slope-scaled bias: the depth of a plane seen from ωi changes by |n_xy| / (n·ωi) per unit of
  // plane distance, and the filter taps lie up to ~1.5 sample spacings from q.
  const float cn = std::max(glm::dot(ng, L.w), 1e-4f);
  const float slope = std::min(std::sqrt(ng.x * ng.x + ng.y * ng.y) / cn, 10.0f);
  const float bias = m_settings.biasScale * m_cell * (0.25f + 1.5f * slope);
  const uint32_t* prims = m_maps.primRow(l);
  const float* depths = m_maps.depthRow(l);
  const float Lx = float(g.Lx), Ly = float(g.Ly);
  const float qx = p.x - p.z * L.slopeX, qy = p.y - p.z * L.slopeY;  // q before wrapping
  const float copy2 = 0.25f * std::min(Lx, Ly) * std::min(Lx, Ly);
  auto lit = [&](int i, int j) -> float {
    const size_t k = size_t(j) * su + i;
    if (r >= depths[k] - bias) return 1.0f;
    if (prims[k] != prim) return 0.0f;
    // A triangle is planar and cannot shadow itself — but a periodic copy of it can: at grazing
    // light the first hit toward the light is often the same triangle one period away. The
    // tap's hit point, on the copy nearest q, must be this copy (within half a period of p).
    float gx = (float(i) + 0.5f) * Lx * m_invSu, gy = (float(j) + 0.5f) * Ly * m_invSv;
    gx += Lx * std::round((qx - gx) / Lx);
    gy += Ly * std::round((qy - gy) / Ly);
    const float d = depths[k];
    const float ex = gx + d * L.w.x - p.x, ey = gy + d * L.w.y - p.y, ez = d * L.w.z - p.z;
    return ex * ex + ey * ey + ez * ez < copy2 ? 1.0f : 0.0f;
  };
  return (lit(i0, j0) * (1 - tx) + lit(i1, j0) * tx) * (1 - ty) +
         (lit(i0, j1) * (1 - tx) + lit(i1, j1) * tx) * ty;
}

int64_t DirectIllumination::evalTexelView(int i, int j, int view, float* out) const {
  const int nL = m_dirs.size();
  std::fill(out, out + size_t(nL) * 3, 0.0f);
  const SampleGrid& g = m_maps.grid();
  const int K2 = g.spp * g.spp;
  const float invK2 = 1.0f / float(K2);
  const DVec3 wv = m_dirs[view].w;
  int64_t evals = 0;
  for (int s = 0; s < K2; ++s) {
    const int64_t si = g.sampleIndex(i, j, s);
    const uint32_t prim = m_maps.prim(view, si);
    if (prim == kNoHit) continue;
    const int a = int(si % g.su()), b = int(si / g.su());
    const DVec3 p0 = g.position(a, b);
    const Vec3 p = Vec3(p0 + double(m_maps.depth(view, si)) * wv);
    Vec3 ng, n;
    if (!hitNormals(m_geom, prim, m_maps.bu(view, si), m_maps.bv(view, si), Vec3(wv), &ng, &n))
      continue;
    const Frame frame = Frame::fromNormal(n);
    const Vec3 wo = frame.toLocal(Vec3(wv));
    const Material& mat = m_materials[m_geom.triMaterial[prim]];
    const bool lambert = mat.type == BrdfType::Lambert;
    const DVec3 origin = DVec3(p) + m_tracer.epsilon() * DVec3(ng);
    for (int l = 0; l < nL; ++l) {
      const LightInfo& L = m_lights[size_t(l)];
      const float cosN = glm::dot(n, L.w);
      if (cosN <= 0 || glm::dot(ng, L.w) <= 0) continue;
      float vis;
      if (m_settings.shadows == ShadowMode::Map && !L.rays) {
        vis = shadowMapVisibility(l, p, ng, prim);
      } else if (m_settings.shadows != ShadowMode::None) {
        vis = m_tracer.occluded(origin, DVec3(L.w)) ? 0.0f : 1.0f;
      } else {
        vis = 1.0f;
      }
      if (vis <= 0) continue;
      // Lambert needs no local frame: its value is constant.
      const Rgb f = lambert ? mat.kdOverPi : evalBrdf(mat, frame.toLocal(L.w), wo);
      const float k = cosN * L.invCos * vis * invK2;
      out[3 * l] += f.x * k;
      out[3 * l + 1] += f.y * k;
      out[3 * l + 2] += f.z * k;
      ++evals;
    }
  }
  return evals;
}

bool DirectIllumination::surface(const DVec3& planePoint, const DVec3& wv, uint32_t prim,
                                 float bu, float bv, float depth, Surface* s) const {
  if (prim == kNoHit) return false;
  s->p = Vec3(planePoint + double(depth) * wv);
  if (!hitNormals(m_geom, prim, bu, bv, Vec3(wv), &s->ng, &s->n)) return false;
  s->frame = Frame::fromNormal(s->n);
  s->wo = s->frame.toLocal(Vec3(wv));
  s->material = m_geom.triMaterial[prim];
  s->mat = &m_materials[s->material];
  s->lambert = s->mat->type == BrdfType::Lambert;
  s->origin = DVec3(s->p) + m_tracer.epsilon() * DVec3(s->ng);
  s->prim = prim;
  return true;
}

Rgb DirectIllumination::contribution(const Surface& s, int l, bool exactShadow) const {
  const LightInfo& L = m_lights[size_t(l)];
  const float cosN = glm::dot(s.n, L.w);
  if (cosN <= 0 || glm::dot(s.ng, L.w) <= 0) return Rgb(0);
  const float vis = exactShadow && m_settings.shadows != ShadowMode::None
                        ? (m_tracer.occluded(s.origin, DVec3(L.w)) ? 0.0f : 1.0f)
                        : lightVisibility(l, s.p, s.ng, s.prim);
  if (vis <= 0) return Rgb(0);
  const Rgb f = s.lambert ? s.mat->kdOverPi : evalBrdf(*s.mat, s.frame.toLocal(L.w), s.wo);
  return f * (cosN * L.invCos * vis);
}

Rgb DirectIllumination::evalTexelViewLight(int i, int j, int view, const DVec3& light) const {
  const SampleGrid& g = m_maps.grid();
  const int K2 = g.spp * g.spp;
  const DVec3 wv = m_dirs[view].w;
  const Vec3 wl(light);
  const float invCos = 1.0f / float(std::max(light.z, 1e-7));
  Rgb sum(0);
  for (int s = 0; s < K2; ++s) {
    const int64_t si = g.sampleIndex(i, j, s);
    const uint32_t prim = m_maps.prim(view, si);
    if (prim == kNoHit) continue;
    const DVec3 p0 = g.position(int(si % g.su()), int(si / g.su()));
    const DVec3 p = p0 + double(m_maps.depth(view, si)) * wv;
    Vec3 ng, n;
    if (!hitNormals(m_geom, prim, m_maps.bu(view, si), m_maps.bv(view, si), Vec3(wv), &ng, &n))
      continue;
    const float cosN = glm::dot(n, wl);
    if (cosN <= 0 || glm::dot(ng, wl) <= 0) continue;
    if (m_settings.shadows != ShadowMode::None &&
        m_tracer.occluded(p + m_tracer.epsilon() * DVec3(ng), light))
      continue;
    const Frame frame = Frame::fromNormal(n);
    sum += evalBrdf(m_materials[m_geom.triMaterial[prim]], frame.toLocal(wl),
                    frame.toLocal(Vec3(wv))) *
           (cosN * invCos);
  }
  return sum / float(K2);
}

}  // namespace btf
