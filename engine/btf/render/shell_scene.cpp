// The render scene: the object, its shell of prisms and their frames, the camera, ray
// footprints, and the flat mode (the BTF looked up on the base surface).
#include "render_internal.h"

namespace btf {

using namespace renderdetail;

RenderScene::RenderScene(ObjectMesh object, double Lx, double Ly, double zmin, double zmax,
                         const RenderSettings& s)
    : m_obj(std::move(object)), m_s(s), m_Lx(Lx), m_Ly(Ly) {
  if (!(s.tiling > 0)) throw Error("--tiling must be positive");
  if (!(s.reliefScale > 0)) throw Error("--relief-scale must be positive");
  if (m_obj.uv.size() != m_obj.pos.size() || m_obj.nrm.size() != m_obj.pos.size())
    throw Error("object " + m_obj.name + " has no texture coordinates on every vertex");
  const double R = m_obj.radius;
  m_k = m_obj.worldPerUv() / (s.tiling * Lx);
  m_K = m_k * s.reliefScale;
  const double pad = 1e-3 * std::max(Lx, Ly);
  m_hlo = zmin - pad, m_hhi = zmax + pad;
  m_eps = 2e-6 * R;
  m_light = lightDirection(s);
  const double T = s.tiling * Lx;  // tile units per uv unit

  // Weld vertices by position and normal: the shell's topology (seams keep their own uv).
  std::map<std::array<int64_t, 6>, uint32_t> weld;
  std::vector<uint32_t> wid(m_obj.pos.size());
  const double qp = 1e-6 * R, qn = 1e-5;
  for (size_t k = 0; k < m_obj.pos.size(); ++k) {
    const Vec3 p = m_obj.pos[k], n = m_obj.nrm[k];
    const std::array<int64_t, 6> key = {std::llround(p.x / qp), std::llround(p.y / qp),
                                        std::llround(p.z / qp), std::llround(n.x / qn),
                                        std::llround(n.y / qn), std::llround(n.z / qn)};
    auto [it, fresh] = weld.try_emplace(key, uint32_t(m_wpos.size()));
    if (fresh) m_wpos.push_back(p), m_wnrm.push_back(glm::normalize(n));
    wid[k] = it->second;
  }
  // Prisms over the non-degenerate base triangles; their tile axes.
  for (uint32_t t = 0; t < m_obj.tri.size(); ++t) {
    const auto& tr = m_obj.tri[t];
    Prism p;
    p.tri = t;
    for (int i = 0; i < 3; ++i) p.w[i] = wid[tr[i]], p.xy[i] = glm::dvec2(m_obj.uv[tr[i]]) * T;
    const DVec3 a(m_obj.pos[tr.x]), b(m_obj.pos[tr.y]), c(m_obj.pos[tr.z]);
    const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
    DVec3 tx(0), ty(0);
    if (p.w[0] != p.w[1] && p.w[1] != p.w[2] && p.w[0] != p.w[2] && area > 1e-12 * R * R) {
      const glm::dvec2 d1 = p.xy[1] - p.xy[0], d2 = p.xy[2] - p.xy[0];
      const double det = cross2(d1, d2);
      if (!(std::abs(det) > 1e-12 * T * T))
        throw Error(
            format("object %s: triangle %u has degenerate texture coordinates (uv (%g, %g), "
                   "(%g, %g), (%g, %g)); the renderer needs a texture map on every triangle",
                   m_obj.name.c_str(), t, m_obj.uv[tr.x].x, m_obj.uv[tr.x].y, m_obj.uv[tr.y].x,
                   m_obj.uv[tr.y].y, m_obj.uv[tr.z].x, m_obj.uv[tr.z].y));
      // [b−a c−a] = [∂P/∂x ∂P/∂y] · [d1 d2]
      tx = ((b - a) * d2.y - (c - a) * d1.y) / det;
      ty = ((c - a) * d1.x - (b - a) * d2.x) / det;
      m_prisms.push_back(p);
      m_baseKept.push_back(t);
    }
    m_triT.push_back(tx), m_triB.push_back(ty);
  }
  if (m_prisms.empty()) throw Error("object " + m_obj.name + " has no triangle with an area");
  // Per vertex, the relief's height scale: the local world length of a tile unit (area-weighted
  // over its triangles) × the relief scale, so a stretched texture map keeps the relief's
  // proportions where it lands.
  {
    std::vector<double> sum(m_wpos.size(), 0), wsum(m_wpos.size(), 0);
    for (const Prism& p : m_prisms) {
      const auto& tr = m_obj.tri[p.tri];
      const double aw = 0.5 * glm::length(glm::cross(DVec3(m_obj.pos[tr.y] - m_obj.pos[tr.x]),
                                                     DVec3(m_obj.pos[tr.z] - m_obj.pos[tr.x])));
      const double at = 0.5 * std::abs(cross2(p.xy[1] - p.xy[0], p.xy[2] - p.xy[0]));
      for (int i = 0; i < 3; ++i) sum[p.w[i]] += aw * std::sqrt(aw / at), wsum[p.w[i]] += aw;
    }
    m_wK.assign(m_wpos.size(), m_K);
    for (size_t w = 0; w < m_wpos.size(); ++w)
      if (wsum[w] > 0) m_wK[w] = sum[w] / wsum[w] * s.reliefScale;
  }

  // The shell may not fold: along every edge the offset surfaces at the bottom and top heights
  // must keep their orientation (1 + d·κ > 0, κ the normal's turn per length along the edge).
  double worst = 1;
  DVec3 worstAt(0);
  double worstR = 0;
  for (const Prism& p : m_prisms)
    for (int i = 0; i < 3; ++i) {
      const DVec3 pa(m_wpos[p.w[i]]), pb(m_wpos[p.w[(i + 1) % 3]]);
      const DVec3 na(m_wnrm[p.w[i]]), nb(m_wnrm[p.w[(i + 1) % 3]]);
      const double l2 = glm::dot(pb - pa, pb - pa);
      if (!(l2 > 0)) continue;
      const double kappa = glm::dot(nb - na, pb - pa) / l2;
      const double Kmax = std::max(m_wK[p.w[i]], m_wK[p.w[(i + 1) % 3]]);
      for (double h : {m_hlo, m_hhi}) {
        const double f = 1 + h * Kmax * kappa;
        if (f < worst) worst = f, worstAt = 0.5 * (pa + pb), worstR = 1 / std::abs(kappa);
      }
    }
  if (worst < 0.05)
    throw Error(
        format("relief scale %g with tiling %g makes the shell on %s fold over itself: the "
               "relief spans %.4g to %.4g world units along the normal but the surface's "
               "radius of curvature is only %.4g near (%.3f, %.3f, %.3f); lower "
               "--relief-scale or raise --tiling",
               s.reliefScale, s.tiling, m_obj.name.c_str(), m_hlo * m_K, m_hhi * m_K, worstR,
               worstAt.x, worstAt.y, worstAt.z));

  // Shell vertices: 2·w + level.
  std::vector<Vec3> sv(m_wpos.size() * 2);
  for (size_t w = 0; w < m_wpos.size(); ++w) {
    sv[2 * w] = Vec3(DVec3(m_wpos[w]) + DVec3(m_wnrm[w]) * (m_hlo * m_wK[w]));
    sv[2 * w + 1] = Vec3(DVec3(m_wpos[w]) + DVec3(m_wnrm[w]) * (m_hhi * m_wK[w]));
  }
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> edges;  // → first of the side's 2 faces
  std::vector<std::vector<int32_t>> attached;
  auto addFace = [&](uint32_t a, uint32_t b, uint32_t c, uint8_t kind) {
    Face f;
    f.v[0] = a, f.v[1] = b, f.v[2] = c, f.kind = kind;
    m_faces.push_back(f);
    attached.emplace_back();
    return uint32_t(m_faces.size() - 1);
  };
  for (int32_t pi = 0; pi < int32_t(m_prisms.size()); ++pi) {
    Prism& p = m_prisms[size_t(pi)];
    const uint32_t a = p.w[0], b = p.w[1], c = p.w[2];
    p.face[0] = addFace(2 * a + 1, 2 * b + 1, 2 * c + 1, 0);
    p.face[1] = addFace(2 * a, 2 * b, 2 * c, 1);
    attached[p.face[0]].push_back(pi);
    attached[p.face[1]].push_back(pi);
    for (int i = 0; i < 3; ++i) {
      const uint32_t u = p.w[i], v = p.w[(i + 1) % 3];
      const auto key = std::make_pair(std::min(u, v), std::max(u, v));
      auto it = edges.find(key);
      if (it == edges.end()) {
        const uint32_t f0 = addFace(2 * u, 2 * v, 2 * v + 1, 2);
        addFace(2 * u, 2 * v + 1, 2 * u + 1, 2);
        it = edges.emplace(key, f0).first;
      }
      p.face[2 + 2 * i] = it->second, p.face[3 + 2 * i] = it->second + 1;
      for (uint32_t f = it->second; f < it->second + 2; ++f) {
        if (attached[f].size() >= 2)
          throw Error(
              format("object %s is not a manifold: an edge near (%.3f, %.3f, %.3f) has more "
                     "than two triangles",
                     m_obj.name.c_str(), m_wpos[u].x, m_wpos[u].y, m_wpos[u].z));
        attached[f].push_back(pi);
      }
    }
  }
  for (Prism& p : m_prisms)
    for (int i = 0; i < 3; ++i) {
      const uint32_t u = p.w[i], v = p.w[(i + 1) % 3];
      const auto& at = attached[edges.at(std::make_pair(std::min(u, v), std::max(u, v)))];
      if (at.size() == 1) p.open |= uint8_t(1u << i);
      for (int32_t q : at)
        if (&m_prisms[size_t(q)] != &p) p.nb[i] = q;
    }
  for (size_t fi = 0; fi < m_faces.size(); ++fi) {
    Face& f = m_faces[fi];
    const DVec3 a(sv[f.v[0]]), b(sv[f.v[1]]), c(sv[f.v[2]]);
    f.n = glm::cross(b - a, c - a);
    const DVec3 fc = (a + b + c) / 3.0;
    for (int32_t pi : attached[fi]) {
      const Prism& p = m_prisms[size_t(pi)];
      DVec3 pc(0);
      for (int i = 0; i < 3; ++i) pc += DVec3(sv[2 * p.w[i]]) + DVec3(sv[2 * p.w[i] + 1]);
      const int side = glm::dot(pc / 6.0 - fc, f.n) >= 0 ? 0 : 1;
      if (f.prism[side] >= 0)
        throw Error(
            format("the shell on %s folds over itself near (%.3f, %.3f, %.3f): lower "
                   "--relief-scale or raise --tiling",
                   m_obj.name.c_str(), fc.x, fc.y, fc.z));
      f.prism[side] = pi;
    }
  }
  m_sv.assign(sv.begin(), sv.end());
  std::vector<glm::uvec3> ft(m_faces.size());
  for (size_t k = 0; k < m_faces.size(); ++k)
    ft[k] = {m_faces[k].v[0], m_faces[k].v[1], m_faces[k].v[2]};
  m_shell = std::make_unique<MeshTracer>(sv, ft);
  std::vector<glm::uvec3> bt;
  for (uint32_t t : m_baseKept) bt.push_back(m_obj.tri[t]);
  m_base = std::make_unique<MeshTracer>(m_obj.pos, bt);
}

RenderScene::~RenderScene() = default;

CameraFrame cameraFrame(const RenderSettings& s, double R) {
  CameraFrame c;
  const DVec3 toCam = fromAngles(s.camTheta, s.camPhi);
  c.fwd = -toCam;
  const DVec3 hint = std::abs(toCam.z) > 0.999 ? DVec3(0, 1, 0) : DVec3(0, 0, 1);
  c.right = glm::normalize(glm::cross(c.fwd, hint));
  c.up = glm::cross(c.right, c.fwd);
  const double aspect = double(s.width) / double(s.height);
  c.perspective = s.perspective;
  if (c.perspective) {
    const double half = deg2rad(std::clamp(s.fovDeg, 1.0, 170.0)) / 2;
    const double dist = std::max(1.05 * R / std::sin(half) / s.zoom, 1.01 * R);
    c.pos = toCam * dist;
    c.hh = std::tan(half), c.hw = c.hh * aspect;
  } else {
    c.pos = toCam * (4 * R);
    c.hh = 1.05 * R / s.zoom, c.hw = c.hh * aspect;
  }
  return c;
}

DVec3 lightDirection(const RenderSettings& s) {
  return fromAngles(s.lightTheta, s.lightPhi);
}

RenderScene::Camera RenderScene::camera() const {
  const CameraFrame f = cameraFrame(m_s, m_obj.radius);
  Camera c;
  c.pos = f.pos, c.fwd = f.fwd, c.right = f.right, c.up = f.up;
  c.persp = f.perspective, c.hw = f.hw, c.hh = f.hh;
  return c;
}

DVec3 RenderScene::tileCoords(const Face& f, int prism, float bu, float bv) const {
  const Prism& p = m_prisms[size_t(prism)];
  const double w[3] = {1.0 - double(bu) - double(bv), double(bu), double(bv)};
  DVec3 r(0);
  for (int k = 0; k < 3; ++k) {
    const uint32_t wv = f.v[k] >> 1;
    const double h = (f.v[k] & 1) ? m_hhi : m_hlo;
    int i = 0;
    while (i < 2 && p.w[i] != wv) ++i;
    r += w[k] * DVec3(p.xy[i].x, p.xy[i].y, h);
  }
  return r;
}

void RenderScene::frameOf(uint32_t baseTri, const DVec3& n, DVec3* t, DVec3* b) const {
  DVec3 tx = m_triT[baseTri] - n * glm::dot(n, m_triT[baseTri]);
  double l = glm::length(tx);
  if (!(l > 1e-12)) {
    tx = std::abs(n.x) < 0.9 ? DVec3(1, 0, 0) : DVec3(0, 1, 0);
    tx -= n * glm::dot(n, tx);
    l = glm::length(tx);
  }
  *t = tx / l;
  *b = glm::cross(n, *t);
  if (glm::dot(*b, m_triB[baseTri]) < 0) *b = -*b;  // mirrored texture map
}

void RenderScene::SampleInfo::set(const BtfSampler::Footprint& fp, const BtfSampler& btf) {
  lod = fp.lod;
  // |a × b| in level-0 texels (a point lookup: one texel).
  const BtfInfo& I = btf.info();
  const double sx = I.nu / I.Lx, sy = I.nv / I.Ly;
  texels = std::abs(fp.a.x * sx * fp.b.y * sy - fp.a.y * sy * fp.b.x * sx);
}

BtfSampler::Footprint RenderScene::footprintAt(uint32_t tri, const DVec3& p, const DVec3& o,
                                               const DVec3& d, const RayDiff& diff,
                                               const BtfSampler& btf) const {
  BtfSampler::Footprint fp;
  if (m_s.forceLevel >= 0) {
    fp.lod = std::min(m_s.forceLevel, btf.levels() - 1);
    return fp;
  }
  // The neighbours' rays meet the triangle's plane at p + dp (tangent-plane transfer, Igehy's
  // ray differentials); the triangle's texture map turns dp into tile units.
  const auto& tr = m_obj.tri[tri];
  const DVec3 p0(m_obj.pos[tr.x]), e1 = DVec3(m_obj.pos[tr.y]) - p0,
                                   e2 = DVec3(m_obj.pos[tr.z]) - p0;
  const glm::dvec2 t0(m_obj.uv[tr.x]), q1 = glm::dvec2(m_obj.uv[tr.y]) - t0,
                                       q2 = glm::dvec2(m_obj.uv[tr.z]) - t0;
  const double det = q1.x * q2.y - q1.y * q2.x;
  const DVec3 n = glm::cross(e1, e2);
  const double T = m_s.tiling * m_Lx;
  auto transfer = [&](const DVec3& dox, const DVec3& ddx) -> glm::dvec2 {
    const DVec3 o2 = o + dox, d2 = d + ddx;
    const double den = glm::dot(d2, n);
    if (!(std::abs(den) > 1e-300) || !(std::abs(det) > 1e-300))
      return glm::dvec2(std::numeric_limits<double>::infinity());
    const DVec3 dp = o2 + d2 * (glm::dot(p - o2, n) / den) - p;
    // dp = α e1 + β e2 in the plane; (du, dv) = α q1 + β q2.
    const double g11 = glm::dot(e1, e1), g12 = glm::dot(e1, e2), g22 = glm::dot(e2, e2);
    const double r1 = glm::dot(dp, e1), r2 = glm::dot(dp, e2), gd = g11 * g22 - g12 * g12;
    if (!(gd > 0)) return glm::dvec2(std::numeric_limits<double>::infinity());
    const double a = (r1 * g22 - r2 * g12) / gd, b = (r2 * g11 - r1 * g12) / gd;
    return (a * q1 + b * q2) * T;
  };
  const glm::dvec2 dx = transfer(diff.dox, diff.ddx), dy = transfer(diff.doy, diff.ddy);
  if (m_s.mip && btf.levels() > 1) return btf.footprint(dx, dy, m_s.maxAniso);
  if (std::isfinite(dx.x + dx.y + dy.x + dy.y)) fp.a = dx, fp.b = dy;  // one tap, level 0
  return fp;
}

RenderImage RenderScene::renderFlat(const BtfSampler& btf, const CancelToken* cancel,
                                    ProgressReporter* progress) const {
  const double T = m_s.tiling * m_Lx;
  const float E = float(m_s.irradiance), Lenv = float(m_s.environment);
  RenderImage img = renderWith(
      "flat", cancel, progress,
      [&](const DVec3& o, const DVec3& d, const RayDiff& diff, Rng&, Rgb* out, uint64_t* rays,
          SampleInfo* info) {
        const MeshHit h = m_base->intersect(o, d);
        ++*rays;
        if (!h.hit()) return false;
        const uint32_t t = m_baseKept[h.prim];
        const auto& tr = m_obj.tri[t];
        const double b[3] = {1.0 - h.u - h.v, h.u, h.v};
        DVec3 n(0), ng;
        glm::dvec2 uv(0);
        for (int k = 0; k < 3; ++k)
          n += b[k] * DVec3(m_obj.nrm[tr[k]]), uv += b[k] * glm::dvec2(m_obj.uv[tr[k]]);
        n = glm::normalize(n);
        ng = glm::normalize(glm::cross(DVec3(m_obj.pos[tr.y] - m_obj.pos[tr.x]),
                                       DVec3(m_obj.pos[tr.z] - m_obj.pos[tr.x])));
        if (glm::dot(ng, n) < 0) ng = -ng;
        if (glm::dot(n, -d) <= 0) return true;  // the back of the surface: black
        DVec3 tx, ty;
        frameOf(t, n, &tx, &ty);
        const DVec3 wo(glm::dot(-d, tx), glm::dot(-d, ty), glm::dot(-d, n));
        const DVec3 wi(glm::dot(m_light, tx), glm::dot(m_light, ty), glm::dot(m_light, n));
        if (wo.z <= 0) return true;
        const DVec3 p = o + d * h.t;
        const BtfSampler::Footprint fp = footprintAt(t, p, o, d, diff, btf);
        info->set(fp, btf);
        if (m_s.showLevel) {
          *out = levelColour(fp.lod);
          return true;
        }
        if (Lenv > 0) *out += Lenv * btf.ambient(uv.x * T, uv.y * T, glm::normalize(wo), &fp);
        if (wi.z <= 0 || !(E > 0)) return true;
        ++*rays;
        if (m_base->occluded(p + ng * m_eps, m_light, m_eps)) return true;
        *out += E * float(wi.z) *
                btf.eval(uv.x * T, uv.y * T, glm::normalize(wo), glm::normalize(wi), &fp);
        return true;
      });
  img.triangles = m_baseKept.size();
  return img;
}

}  // namespace btf
