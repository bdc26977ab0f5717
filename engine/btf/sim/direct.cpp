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
  return mapVisibility(l, p, std::max(glm::dot(ng, m_lights[size_t(l)].w), 1e-4f),
                       std::sqrt(ng.x * ng.x + ng.y * ng.y), prim);
}

float DirectIllumination::mapVisibility(int l, const Vec3& p, float cn, float ngXY, uint32_t prim,
                                        bool* decided) const {
  const LightInfo& L = m_lights[size_t(l)];
  const SampleGrid& g = m_maps.grid();
  // Project p along ωi onto the plane: q = p − (p.z / cos θi) ωi; r is p's distance along ωi.
  // Float is enough: even at θ = 89.9° the offset spans < 10⁴ samples (ulp < 10⁻³ sample).
  const float r = p.z * L.invCos;
  const int su = g.su(), sv = g.sv();
  const float qx = p.x - p.z * L.slopeX, qy = p.y - p.z * L.slopeY;  // q before wrapping
  float fx = qx * m_toSampleX - 0.5f;
  float fy = qy * m_toSampleY - 0.5f;
  fx -= std::floor(fx * m_invSu) * float(su);
  fy -= std::floor(fy * m_invSv) * float(sv);
  int i0 = int(fx), j0 = int(fy);
  const float tx = fx - float(i0), ty = fy - float(j0);
  i0 = std::min(std::max(i0, 0), su - 1);
  j0 = std::min(std::max(j0, 0), sv - 1);
  const int i1 = i0 + 1 == su ? 0 : i0 + 1, j1 = j0 + 1 == sv ? 0 : j0 + 1;
  // Slope-scaled bias: the depth of a plane seen from ωi changes by |n_xy| / (n·ωi) per unit of
  // plane distance, and the filter taps lie up to ~1.5 sample spacings from q.
  const float slope = std::min(ngXY / std::max(cn, 1e-4f), 10.0f);
  const float bias = m_settings.biasScale * m_cell * (0.25f + 1.5f * slope);
  const uint32_t* prims = m_maps.primRow(l);
  const float* depths = m_maps.depthRow(l);
  const float rb = r + bias;
  const size_t k00 = size_t(j0) * su + i0, k10 = size_t(j0) * su + i1;
  const size_t k01 = size_t(j1) * su + i0, k11 = size_t(j1) * su + i1;
  const float Lx = float(g.Lx), Ly = float(g.Ly);
  const float copy2 = 0.25f * std::min(Lx, Ly) * std::min(Lx, Ly);
  auto lit = [&](int i, int j, size_t k) -> float {
    if (rb >= depths[k]) return 1.0f;
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
  if (decided) {
    // The map decides p when the 3 × 3 taps around p's own map cell agree: map samples are
    // jittered within their cells, so only the neighbouring cells' lie on both sides of p.
    auto wrap = [](int v, int n) { return v < 0 ? v + n : v >= n ? v - n : v; };
    const int ci = tx < 0.5f ? i0 : i1, cj = ty < 0.5f ? j0 : j1;
    // Every tap lit: the 2 × 2 blocks holding the 3 × 3 taps have their maxima below p.
    const float* bm = m_maps.blockMaxRow(l);
    if (bm && !(su & 1) && !(sv & 1)) {
      const size_t bw = size_t(su >> 1);
      const size_t r0 = size_t(wrap(cj - 1, sv) >> 1) * bw, r1 = size_t(wrap(cj + 1, sv) >> 1) * bw;
      const size_t c0 = size_t(wrap(ci - 1, su) >> 1), c1 = size_t(wrap(ci + 1, su) >> 1);
      if (rb >= bm[r0 + c0] && rb >= bm[r0 + c1] && rb >= bm[r1 + c0] && rb >= bm[r1 + c1]) {
        *decided = true;
        return 1.0f;
      }
    }
    const float first = lit(ci, cj, size_t(cj) * su + ci);
    for (int b = -1; b <= 1; ++b) {
      const int jj = wrap(cj + b, sv);
      for (int a = -1; a <= 1; ++a) {
        const int ii = wrap(ci + a, su);
        if ((a || b) && lit(ii, jj, size_t(jj) * su + ii) != first) {
          *decided = false;
          return first;
        }
      }
    }
    *decided = true;
    return first;
  }
  // The common case: every tap lies beyond p (lit), no triangle test needed.
  if (rb >= depths[k00] && rb >= depths[k10] && rb >= depths[k01] && rb >= depths[k11]) return 1.0f;
  return (lit(i0, j0, k00) * (1 - tx) + lit(i1, j0, k10) * tx) * (1 - ty) +
         (lit(i0, j1, k01) * (1 - tx) + lit(i1, j1, k11) * tx) * ty;
}

Rgb DirectIllumination::brdf(const Material& mat, const Frame& frame, const Vec3& wo,
                             const Vec3& wv, float cosN, float won, int l) const {
  const Vec3& w = m_lights[size_t(l)].w;
  if (mat.type != BrdfType::BlinnPhong) return evalBrdf(mat, frame.toLocal(w), wo);
  const float h2 = 2.0f + 2.0f * glm::dot(w, wv);
  if (h2 <= 1e-20f) return mat.kdOverPi;
  const float ch = (cosN + won) / std::sqrt(h2);
  return mat.kdOverPi + mat.ks * (mat.phongNorm * powLobe(std::min(std::max(ch, 0.0f), 1.0f),
                                                          mat.exponent, mat.wholeExponent));
}

namespace {

// One camera sample of the uniform kernel, ready to be lit.
struct KernelSample {
  Vec3 p, ng, n, wo;
  Frame frame;
  DVec3 origin;
  const Material* mat;
  float won, ngXY;
  uint32_t prim;
  int texel;
  bool lambert;
};

}  // namespace

int64_t DirectIllumination::evalTexelView(int i, int j, int view, float* out) const {
  return evalTexelsView(&i, &j, 1, view, &out);
}

int64_t DirectIllumination::evalTexelsView(const int* ti, const int* tj, int count, int view,
                                           float* const* out) const {
  const int nL = m_dirs.size();
  for (int t = 0; t < count; ++t) std::fill(out[t], out[t] + size_t(nL) * 3, 0.0f);
  const SampleGrid& g = m_maps.grid();
  const int K2 = g.spp * g.spp;
  const float invK2 = 1.0f / float(K2);
  const DVec3 wv = m_dirs[view].w;
  const Vec3 wvf(wv);
  const bool mapMode = m_settings.shadows == ShadowMode::Map;
  // The samples that see a surface, texel by texel in sample order (so each texel's sums run in
  // the same order as one texel alone).
  thread_local std::vector<KernelSample> samples;
  samples.clear();
  for (int t = 0; t < count; ++t)
    for (int s = 0; s < K2; ++s) {
      const int64_t si = g.sampleIndex(ti[t], tj[t], s);
      const uint32_t prim = m_maps.prim(view, si);
      if (prim == kNoHit || (!m_skip.empty() && m_skip[prim])) continue;
      KernelSample S;
      const DVec3 p0 = g.position(int(si % g.su()), int(si / g.su()));
      S.p = Vec3(p0 + double(m_maps.depth(view, si)) * wv);
      if (!hitNormals(m_geom, prim, m_maps.bu(view, si), m_maps.bv(view, si), wvf, &S.ng, &S.n))
        continue;
      S.mat = &m_materials[m_geom.triMaterial[prim]];
      S.lambert = S.mat->type == BrdfType::Lambert;
      S.won = glm::dot(S.n, wvf);
      // Every model but the Lambert shortcut is zero when the shading normal faces away.
      if (!S.lambert && S.won <= 0) continue;
      const bool local = !S.lambert && S.mat->type != BrdfType::BlinnPhong;
      if (local) {
        S.frame = Frame::fromNormal(S.n);
        S.wo = S.frame.toLocal(wvf);
      } else {
        S.wo = Vec3(0, 0, S.won);
      }
      S.ngXY = std::sqrt(S.ng.x * S.ng.x + S.ng.y * S.ng.y);
      S.origin = DVec3(S.p) + m_tracer.epsilon() * DVec3(S.ng);
      S.prim = prim;
      S.texel = t;
      samples.push_back(S);
    }
  int64_t evals = 0;
  for (int l = 0; l < nL; ++l) {
    const LightInfo& L = m_lights[size_t(l)];
    const bool useMap = mapMode && !L.rays;
    for (const KernelSample& S : samples) {
      const float cosN = glm::dot(S.n, L.w);
      const float cn = glm::dot(S.ng, L.w);
      if (cosN <= 0 || cn <= 0) continue;
      float vis;
      if (useMap) {
        vis = mapVisibility(l, S.p, cn, S.ngXY, S.prim);
      } else if (m_settings.shadows != ShadowMode::None) {
        vis = m_tracer.occluded(S.origin, DVec3(L.w)) ? 0.0f : 1.0f;
      } else {
        vis = 1.0f;
      }
      if (vis <= 0) continue;
      // Lambert needs no local frame: its value is constant.
      const Rgb f = S.lambert ? S.mat->kdOverPi : brdf(*S.mat, S.frame, S.wo, wvf, cosN, S.won, l);
      const float k = cosN * L.invCos * vis * invK2;
      float* o = out[S.texel] + 3 * l;
      o[0] += f.x * k;
      o[1] += f.y * k;
      o[2] += f.z * k;
      ++evals;
    }
  }
  return evals;
}

bool DirectIllumination::surface(const DVec3& planePoint, const DVec3& wv, uint32_t prim, float bu,
                                 float bv, float depth, Surface* s) const {
  if (prim == kNoHit) return false;
  s->p = Vec3(planePoint + double(depth) * wv);
  if (!hitNormals(m_geom, prim, bu, bv, Vec3(wv), &s->ng, &s->n)) return false;
  s->frame = Frame::fromNormal(s->n);
  s->wv = Vec3(wv);
  s->wo = s->frame.toLocal(s->wv);
  s->ngXY = std::sqrt(s->ng.x * s->ng.x + s->ng.y * s->ng.y);
  s->material = m_geom.triMaterial[prim];
  s->mat = &m_materials[s->material];
  s->lambert = s->mat->type == BrdfType::Lambert;
  s->origin = DVec3(s->p) + m_tracer.epsilon() * DVec3(s->ng);
  s->prim = prim;
  return true;
}

Rgb DirectIllumination::unshadowed(const Surface& s, int l) const {
  const LightInfo& L = m_lights[size_t(l)];
  const float cosN = glm::dot(s.n, L.w);
  const float cn = glm::dot(s.ng, L.w);
  if (cosN <= 0 || cn <= 0) return Rgb(0);
  if (!s.lambert && s.wo.z <= 0) return Rgb(0);
  const Rgb f = s.lambert ? s.mat->kdOverPi : brdf(*s.mat, s.frame, s.wo, s.wv, cosN, s.wo.z, l);
  return f * (cosN * L.invCos);
}

float DirectIllumination::visibility(const Surface& s, int l, bool exactShadow,
                                     bool* mapDecided) const {
  const LightInfo& L = m_lights[size_t(l)];
  if (m_settings.shadows == ShadowMode::Map && !L.rays) {
    // Near a shadow edge (exactShadow): the map where its taps agree, else an exact ray.
    const float cn = std::max(glm::dot(s.ng, L.w), 1e-4f);
    bool decided = true;
    const float vis = mapVisibility(l, s.p, cn, s.ngXY, s.prim, exactShadow ? &decided : nullptr);
    if (mapDecided) *mapDecided = decided;
    if (decided) return vis;
  } else if (m_settings.shadows == ShadowMode::None) {
    return 1.0f;
  }
  return m_tracer.occluded(s.origin, DVec3(L.w)) ? 0.0f : 1.0f;
}

Rgb DirectIllumination::contribution(const Surface& s, int l, bool exactShadow) const {
  const Rgb f = unshadowed(s, l);
  if (f.x == 0 && f.y == 0 && f.z == 0) return f;
  return f * visibility(s, l, exactShadow);
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
    if (prim == kNoHit || (!m_skip.empty() && m_skip[prim])) continue;
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
