// The mapped mode (thesis §4.3): rays followed face to face through the shell of prisms, the
// visibility map deciding each segment's hit, and the light traced back out through the shell.
#include "render_internal.h"

namespace btf {

using namespace renderdetail;

bool RenderScene::onObject(int p, glm::dvec2 x) const {
  for (int step = 0; step < 16; ++step) {
    const Prism& P = m_prisms[size_t(p)];
    const double det = cross2(P.xy[1] - P.xy[0], P.xy[2] - P.xy[0]);
    int worstEdge = -1;
    double worst = -1e-9;
    for (int k = 0; k < 3; ++k) {
      const double b = cross2(P.xy[(k + 2) % 3] - P.xy[(k + 1) % 3], x - P.xy[(k + 1) % 3]) / det;
      if (b < worst) worst = b, worstEdge = (k + 1) % 3;  // edge (k+1, k+2) is edge index k+1
    }
    if (worstEdge < 0) return true;
    if (P.open & (1u << worstEdge)) return false;
    const int q = P.nb[worstEdge];
    if (q < 0) return false;
    // Into the neighbour's coordinates (they differ by whole periods across a seam).
    const Prism& Q = m_prisms[size_t(q)];
    const uint32_t shared = P.w[worstEdge];
    int iq = 0;
    while (iq < 2 && Q.w[iq] != shared) ++iq;
    x += Q.xy[iq] - P.xy[worstEdge];
    p = q;
  }
  return true;  // far from any edge it could cross: accept
}

DVec3 RenderScene::tileDir(int prism, const DVec3& t, const DVec3& d) const {
  // Directions live in the orthonormal frame of the point (the interpolated normal, the tile's
  // x axis projected): the BTF was simulated on an undistorted tile, so a stretched texture map
  // changes where texels land (positions follow the prism map), not the angles.
  const Prism& P = m_prisms[size_t(prism)];
  const glm::dvec2 e1 = P.xy[1] - P.xy[0], e2 = P.xy[2] - P.xy[0];
  const double det = cross2(e1, e2);
  const glm::dvec2 x(t.x, t.y);
  const double b1 = cross2(x - P.xy[0], e2) / det, b2 = cross2(e1, x - P.xy[0]) / det;
  DVec3 n = (1 - b1 - b2) * DVec3(m_wnrm[P.w[0]]) + b1 * DVec3(m_wnrm[P.w[1]]) +
            b2 * DVec3(m_wnrm[P.w[2]]);
  const double l = glm::length(n);
  n = l > 0 ? n / l : DVec3(m_wnrm[P.w[0]]);
  DVec3 tx, ty;
  frameOf(P.tri, n, &tx, &ty);
  const DVec3 v(glm::dot(d, tx), glm::dot(d, ty), glm::dot(d, n));
  const double lv = glm::length(v);
  return lv > 0 ? v / lv : DVec3(0, 0, 1);
}

bool RenderScene::segmentHit(int prism, const DVec3& tin, const DVec3& tout, const DVec3& pin,
                             const DVec3& pout, const DVec3& d, const BtfSampler& btf, Rng& rng,
                             bool* ahead, MarchHit* hit, int vmfLevel) const {
  // The view direction in tile space from the prism map's Jacobian at the segment's middle
  // (the chord between entry and exit is ill-conditioned in a thin shell).
  const DVec3 w = tileDir(prism, 0.5 * (tin + tout), -d);
  if (!(w.z > 1e-9)) return false;          // rising or level in tile space: the VMF has no answer
  const DVec3 c = tin - (tin.z / w.z) * w;  // the line's crossing of the reference plane
  float cov, zh;
  btf.vmf(c.x, c.y, w, &cov, &zh, vmfLevel);
  if (!(cov > 0)) return false;
  const double lo = std::min(tin.z, tout.z), hi = std::max(tin.z, tout.z);
  // The hit must lie within this segment's heights. Below, it is a later prism's (and `ahead`
  // records that a line has put it further on). Above, the line meets relief behind the
  // segment: when an earlier line had put the hit ahead, the hit lies at the junction of the two
  // (the surface's curvature bent the ray between them) and is taken at the entry; otherwise the
  // ray's path through the earlier prisms passed over it — a grazing ray at a silhouette passes
  // over relief that this straight line would meet.
  if (double(zh) < lo - 1e-9) {
    *ahead = true;
    return false;
  }
  if (double(zh) > hi + 1e-9 && !*ahead) return false;
  if (cov < 1 && rng.uniform() >= cov) return false;
  // The exact object ends at its boundary edges (its micro-geometry is clipped there): a relief
  // point beyond the object's texture domain is not on the object.
  const DVec3 at = c + (double(zh) / w.z) * w;
  if (!onObject(prism, glm::dvec2(at.x, at.y))) return false;
  const double zc = std::min(double(zh), hi);
  const double dz = tin.z - tout.z;
  const double s = dz > 1e-12 ? std::clamp((tin.z - zc) / dz, 0.0, 1.0) : 0.0;
  hit->tile = tin + s * (tout - tin);
  hit->world = pin + s * (pout - pin);
  hit->crossing = DVec3(c.x, c.y, 0);
  hit->wo = w;
  return true;
}

bool RenderScene::nextFace(int prism, const DVec3& o, const DVec3& d, double tmin,
                           MeshHit* h) const {
  const Prism& P = m_prisms[size_t(prism)];
  constexpr double kEdge = 1e-9;  // a hair of overlap on the edges: no leak between triangles
  double best = std::numeric_limits<double>::infinity();
  for (uint32_t fi : P.face) {
    const Face& f = m_faces[fi];
    const DVec3& v0 = m_sv[f.v[0]];
    const DVec3 e1 = m_sv[f.v[1]] - v0, e2 = m_sv[f.v[2]] - v0;
    const DVec3 pv = glm::cross(d, e2);
    const double det = glm::dot(e1, pv);
    if (!(std::abs(det) > 0)) continue;
    const double inv = 1 / det;
    const DVec3 tv = o - v0;
    const double u = glm::dot(tv, pv) * inv;
    if (u < -kEdge || u > 1 + kEdge) continue;
    const DVec3 qv = glm::cross(tv, e1);
    const double v = glm::dot(d, qv) * inv;
    if (v < -kEdge || u + v > 1 + kEdge) continue;
    const double t = glm::dot(e2, qv) * inv;
    if (t > tmin && t < best) {
      best = t;
      h->prim = fi, h->t = t;
      h->u = float(std::clamp(u, 0.0, 1.0)), h->v = float(std::clamp(v, 0.0, 1.0 - h->u));
    }
  }
  return std::isfinite(best);
}

RenderScene::MarchResult RenderScene::march(const DVec3& o, const DVec3& d, double tmin,
                                            const BtfSampler& btf, Rng& rng, MarchHit* hit,
                                            uint64_t* rays, const RayDiff* diff) const {
  double tnear = tmin;
  int cur = -1;
  bool ahead = false;
  // The VMF's level: the footprint's where the camera ray enters the shell (rounded down: the
  // silhouette keeps the finest detail the footprint resolves); level 0 for light rays.
  int vmfLevel = m_s.forceLevel >= 0 ? m_s.forceLevel : 0;
  BtfSampler::Footprint fp;
  if (m_s.forceLevel >= 0) fp.lod = m_s.forceLevel;
  DVec3 tin(0), pin(0);
  for (int step = 0; step < 1 << 16; ++step) {
    MeshHit h;
    if (cur < 0 || !nextFace(cur, o, d, tnear, &h)) {
      h = m_shell->intersect(o, d, tnear);
      ++*rays;
      if (!h.hit()) return kMiss;
    }
    const Face& f = m_faces[h.prim];
    const bool intoFront = glm::dot(d, f.n) > 0;
    const int from = f.prism[intoFront ? 1 : 0], to = f.prism[intoFront ? 0 : 1];
    const DVec3 p = o + d * h.t;
    if (from >= 0 && from == cur) {
      const DVec3 tout = tileCoords(f, from, h.u, h.v);
      if (segmentHit(from, tin, tout, pin, p, d, btf, rng, &ahead, hit, vmfLevel)) {
        hit->prism = from;
        hit->fp = fp;
        return kRelief;
      }
    }
    if (to >= 0) {
      if (cur < 0 && f.kind == 1) return kAbsorbed;  // from inside the object: its underside
      if (cur < 0) ahead = false;                    // entering the shell from outside
      if (cur < 0 && diff && m_s.forceLevel < 0) {
        fp = footprintAt(m_prisms[size_t(to)].tri, p, o, d, *diff, btf);
        vmfLevel = int(fp.lod);
      }
      cur = to, tin = tileCoords(f, to, h.u, h.v), pin = p;
    } else {
      cur = -1;
    }
    tnear = h.t + m_eps;
  }
  return kMiss;
}

bool RenderScene::lightAt(const MarchHit& hit, const BtfSampler& btf, Rng& rng, DVec3* wi,
                          uint64_t* rays) const {
  // Out of the shell toward the light; the direction is the light's in the tile space of the
  // prism where the ray leaves (its Jacobian at the exit point).
  const DVec3 o = hit.world, L = m_light;
  int cur = hit.prism;
  double tnear = m_eps;
  for (int step = 0; step < 1 << 16; ++step) {
    MeshHit h;
    if (!nextFace(cur, o, L, tnear, &h)) {
      h = m_shell->intersect(o, L, tnear);
      ++*rays;
    }
    if (!h.hit()) {
      // Only when the hit point was placed a hair outside the shell (it is interpolated along
      // the camera's segment): the light leaves from the hit's own prism.
      const DVec3 w = tileDir(hit.prism, hit.tile, L);
      if (!(w.z > 0)) return false;
      *wi = w;
      return true;
    }
    const Face& f = m_faces[h.prim];
    const bool intoFront = glm::dot(L, f.n) > 0;
    const int from = f.prism[intoFront ? 1 : 0], to = f.prism[intoFront ? 0 : 1];
    if (to < 0) {
      if (f.kind == 1) return false;  // into the object: the light is behind it
      const int last = from >= 0 ? from : cur;
      if (last < 0) return false;
      const DVec3 w = tileDir(last, tileCoords(f, last, h.u, h.v), L);
      if (!(w.z > 0)) return false;
      MarchHit other;
      const MarchResult m = march(o, L, h.t + m_eps, btf, rng, &other, rays);
      if (m != kMiss) return false;  // another part of the object casts its shadow
      *wi = w;
      return true;
    }
    cur = to;
    tnear = h.t + m_eps;
  }
  return false;
}

RenderImage RenderScene::renderMapped(const BtfSampler& btf, const CancelToken* cancel,
                                      ProgressReporter* progress) const {
  const float E = float(m_s.irradiance), Lenv = float(m_s.environment);
  RenderImage img = renderWith(
      "mapped", cancel, progress,
      [&](const DVec3& o, const DVec3& d, const RayDiff& diff, Rng& rng, Rgb* out, uint64_t* rays,
          SampleInfo* info) {
        MarchHit hit;
        const MarchResult m = march(o, d, 0.0, btf, rng, &hit, rays, &diff);
        if (m == kMiss) return false;
        if (m == kAbsorbed) return true;
        info->set(hit.fp, btf);
        if (m_s.showLevel) {
          *out = levelColour(hit.fp.lod);
          return true;
        }
        if (Lenv > 0) *out += Lenv * btf.ambient(hit.crossing.x, hit.crossing.y, hit.wo, &hit.fp);
        DVec3 wi;
        if (!(E > 0) || !lightAt(hit, btf, rng, &wi, rays)) return true;
        *out += E * float(wi.z) * btf.eval(hit.crossing.x, hit.crossing.y, hit.wo, wi, &hit.fp);
        return true;
      });
  img.triangles = m_faces.size();
  return img;
}

}  // namespace btf
