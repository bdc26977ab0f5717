#include <btf/core/error.h>
#include <btf/render/mesh_tracer.h>
#include <btf/trace/embree_device.h>

#include <algorithm>
#include <mutex>
#include <string>

namespace btf {

struct MeshTracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  EmbreeErrors errors;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

MeshTracer::MeshTracer(const std::vector<Vec3>& pos, const std::vector<glm::uvec3>& tri)
    : m_impl(std::make_unique<Impl>()) {
  if (tri.empty()) throw Error("cannot trace an empty mesh");
  Impl& im = *m_impl;
  im.device = newEmbreeDevice(&im.errors);
  im.scene = rtcNewScene(im.device);
  rtcSetSceneFlags(im.scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(im.scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry g = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), pos.size()));
  auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), tri.size()));
  if (!vb || !ib) {
    rtcReleaseGeometry(g);
    throw Error("Embree could not allocate the geometry buffers (" + std::to_string(tri.size()) +
                " triangles)");
  }
  for (size_t k = 0; k < pos.size(); ++k)
    vb[3 * k] = pos[k].x, vb[3 * k + 1] = pos[k].y, vb[3 * k + 2] = pos[k].z;
  for (size_t k = 0; k < tri.size(); ++k)
    ib[3 * k] = tri[k].x, ib[3 * k + 1] = tri[k].y, ib[3 * k + 2] = tri[k].z;
  rtcCommitGeometry(g);
  rtcAttachGeometry(im.scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(im.scene);
  if (!im.errors.message.empty()) throw Error(im.errors.message);
}

MeshTracer::~MeshTracer() = default;

namespace {
void setRay(RTCRay& r, const DVec3& o, const DVec3& d, double tmin, double tmax) {
  r.org_x = float(o.x), r.org_y = float(o.y), r.org_z = float(o.z);
  r.dir_x = float(d.x), r.dir_y = float(d.y), r.dir_z = float(d.z);
  r.tnear = float(tmin);
  r.tfar = float(std::min(tmax, 3.0e38));
  r.time = 0, r.mask = 0xffffffffu, r.id = 0, r.flags = 0;
}
}  // namespace

MeshHit MeshTracer::intersect(const DVec3& o, const DVec3& d, double tmin, double tmax) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  setRay(rh.ray, o, d, tmin, tmax);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(m_impl->scene, &ctx, &rh);
  MeshHit h;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
  h.prim = rh.hit.primID, h.u = rh.hit.u, h.v = rh.hit.v, h.t = double(rh.ray.tfar);
  return h;
}

bool MeshTracer::occluded(const DVec3& o, const DVec3& d, double tmin, double tmax) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  setRay(r, o, d, tmin, tmax);
  rtcOccluded1(m_impl->scene, &ctx, &r);
  return r.tfar < 0;
}

}  // namespace btf
