// Ray tracing of an ordinary (non-periodic) triangle mesh on Embree 3: the renderer's object,
// its shell of prisms and the exact micro-geometry mapped onto it. Embree stays behind this
// header.
#pragma once
#include <btf/core/math.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace btf {

struct MeshHit {
  uint32_t prim = 0xffffffffu;
  float u = 0, v = 0;  // Embree barycentrics: p = (1-u-v) p0 + u p1 + v p2
  double t = std::numeric_limits<double>::infinity();
  bool hit() const { return prim != 0xffffffffu; }
};

class MeshTracer {
 public:
  MeshTracer(const std::vector<Vec3>& pos, const std::vector<glm::uvec3>& tri);
  ~MeshTracer();
  MeshTracer(const MeshTracer&) = delete;
  MeshTracer& operator=(const MeshTracer&) = delete;
  /// First hit on o + t d, t in (tmin, tmax).
  MeshHit intersect(const DVec3& o, const DVec3& d, double tmin = 0,
                    double tmax = std::numeric_limits<double>::infinity()) const;
  bool occluded(const DVec3& o, const DVec3& d, double tmin = 0,
                double tmax = std::numeric_limits<double>::infinity()) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace btf
