#include <btf/core/error.h>
#include <btf/trace/embree_device.h>
#include <btf/trace/periodic_tracer.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

namespace btf {

struct PeriodicTracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  EmbreeErrors errors;
  std::vector<uint32_t> copyToPrim;  // Embree primID → original triangle
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

PeriodicTracer::PeriodicTracer(const TileGeometry& g)
    : m_geom(g), m_impl(std::make_unique<Impl>()) {
  BTF_CHECK(g.Lx > 0 && g.Ly > 0);
  if (g.mesh.tri.empty()) throw Error("cannot trace an empty scene");
  const double extent = std::max({g.Lx, g.Ly, double(g.zmax - g.zmin)});
  m_eps = 1e-4 * extent;
  Impl& im = *m_impl;
  im.device = newEmbreeDevice(&im.errors);
  im.scene = rtcNewScene(im.device);
  rtcSetSceneFlags(im.scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(im.scene, RTC_BUILD_QUALITY_HIGH);

  // Every triangle, shifted by each whole period that makes it overlap the closed cell column
  // [0, Lx] × [0, Ly] (with a margin): then the segment of a ray inside the cell sees all the
  // periodic geometry there, including parts that straddle the border.
  std::vector<float> verts;
  std::vector<uint32_t> idx;
  const double m = m_eps;
  for (uint32_t t = 0; t < g.mesh.tri.size(); ++t) {
    const auto& tri = g.mesh.tri[t];
    const Vec3 a = g.mesh.pos[tri.x], b = g.mesh.pos[tri.y], c = g.mesh.pos[tri.z];
    const Vec3 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
    const int i0 = int(std::ceil((-m - hi.x) / g.Lx)),
              i1 = int(std::floor((g.Lx + m - lo.x) / g.Lx));
    const int j0 = int(std::ceil((-m - hi.y) / g.Ly)),
              j1 = int(std::floor((g.Ly + m - lo.y) / g.Ly));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const Vec3 off(float(i * g.Lx), float(j * g.Ly), 0.f);
        const uint32_t base = uint32_t(verts.size() / 3);
        for (const Vec3& p : {a, b, c}) {
          const Vec3 q = p + off;
          verts.insert(verts.end(), {q.x, q.y, q.z});
        }
        idx.insert(idx.end(), {base, base + 1, base + 2});
        im.copyToPrim.push_back(t);
      }
  }
  m_embreeTriangles = im.copyToPrim.size();
  RTCGeometry geom = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), verts.size() / 3));
  auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), idx.size() / 3));
  if (!vb || !ib) throw Error("Embree could not allocate the geometry buffers");
  std::copy(verts.begin(), verts.end(), vb);
  std::copy(idx.begin(), idx.end(), ib);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(im.scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(im.scene);
  if (!im.errors.message.empty()) throw Error(im.errors.message);
}

PeriodicTracer::~PeriodicTracer() = default;

template <bool kOcclusion>
RayHit PeriodicTracer::march(const DVec3& o, const DVec3& d, double tmin, double tmax) const {
  RayHit res;
  const double Lx = m_geom.Lx, Ly = m_geom.Ly;
  const double zlo = double(m_geom.zmin) - m_eps, zhi = double(m_geom.zmax) + m_eps;
  double t0 = tmin, t1 = tmax;
  if (d.z == 0) {
    if (o.z < zlo || o.z > zhi) return res;
  } else {
    double ta = (zlo - o.z) / d.z, tb = (zhi - o.z) / d.z;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (!(t0 <= t1) || !std::isfinite(t0)) return res;
  if (!std::isfinite(t1)) return res;  // a horizontal ray inside the slab: not a traced case
  const DVec3 p = o + t0 * d;
  DVec3 q(p.x - std::floor(p.x / Lx) * Lx, p.y - std::floor(p.y / Ly) * Ly, p.z);
  q.x = std::clamp(q.x, 0.0, Lx);
  q.y = std::clamp(q.y, 0.0, Ly);
  double tb = t0;
  const double span = t1 - t0;
  const int64_t maxSteps = 4 + int64_t(std::ceil(std::abs(d.x) * span / Lx)) +
                           int64_t(std::ceil(std::abs(d.y) * span / Ly));
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  for (int64_t step = 0; step <= maxSteps; ++step) {
    const double tx = d.x > 0 ? (Lx - q.x) / d.x : d.x < 0 ? -q.x / d.x : INFINITY;
    const double ty = d.y > 0 ? (Ly - q.y) / d.y : d.y < 0 ? -q.y / d.y : INFINITY;
    const double texit = std::min(tx, ty);
    const double seg = std::min(texit, t1 - tb);
    RTCRayHit rh;
    rh.ray.org_x = float(q.x);
    rh.ray.org_y = float(q.y);
    rh.ray.org_z = float(q.z);
    rh.ray.dir_x = float(d.x);
    rh.ray.dir_y = float(d.y);
    rh.ray.dir_z = float(d.z);
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = float(seg);
    rh.ray.time = 0;
    rh.ray.mask = 0xffffffffu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    if constexpr (kOcclusion) {
      rtcOccluded1(m_impl->scene, &ctx, &rh.ray);
      if (rh.ray.tfar < 0) {
        res.prim = 0;
        res.t = tb;
        return res;
      }
    } else {
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(m_impl->scene, &ctx, &rh);
      if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        res.prim = m_impl->copyToPrim[rh.hit.primID];
        res.u = rh.hit.u;
        res.v = rh.hit.v;
        res.t = tb + double(rh.ray.tfar);
        return res;
      }
    }
    if (texit >= t1 - tb) return res;
    q += texit * d;
    tb += texit;
    // Wrap exactly: the side(s) we left through become the opposite side(s).
    if (tx <= ty) q.x = d.x > 0 ? 0.0 : Lx;
    if (ty <= tx) q.y = d.y > 0 ? 0.0 : Ly;
    q.x = std::clamp(q.x, 0.0, Lx);
    q.y = std::clamp(q.y, 0.0, Ly);
  }
  BTF_CHECK_MSG(false, "periodic ray march exceeded its step bound");
  return res;
}

RayHit PeriodicTracer::intersect(const DVec3& o, const DVec3& d, double tmin, double tmax) const {
  return march<false>(o, d, tmin, tmax);
}

bool PeriodicTracer::occluded(const DVec3& o, const DVec3& d, double tmin, double tmax) const {
  return march<true>(o, d, tmin, tmax).hit();
}

}  // namespace btf
