// Ray tracing of a periodic tile on Embree 3. A ray that leaves the tile's column through a side
// re-enters through the opposite side: the tracer marches cell by cell (2D DDA) and asks Embree
// only for the segment inside the current cell, so the result is true periodicity, exact on edges
// and corners, and the loop is bounded by the cells crossed inside the geometry's z-slab.
// Embree stays behind this header (no rtcore.h leaks out).
#pragma once
#include <btf/core/math.h>
#include <btf/geometry/mesh.h>

#include <cstdint>
#include <limits>
#include <memory>

namespace btf {

inline constexpr uint32_t kNoHit = 0xffffffffu;

struct RayHit {
  uint32_t prim = kNoHit;  // triangle index in TileGeometry
  float u = 0, v = 0;      // Embree barycentrics: p = (1-u-v) p0 + u p1 + v p2
  double t = std::numeric_limits<double>::infinity();
  bool hit() const { return prim != kNoHit; }
};

class PeriodicTracer {
 public:
  explicit PeriodicTracer(const TileGeometry& geometry);
  ~PeriodicTracer();
  PeriodicTracer(const PeriodicTracer&) = delete;
  PeriodicTracer& operator=(const PeriodicTracer&) = delete;

  /// First hit along o + t d for t in [tmin, tmax]; d must be unit length. o may lie anywhere.
  RayHit intersect(const DVec3& o, const DVec3& d, double tmin = 0,
                   double tmax = std::numeric_limits<double>::infinity()) const;
  /// True when anything lies on the segment.
  bool occluded(const DVec3& o, const DVec3& d, double tmin = 0,
                double tmax = std::numeric_limits<double>::infinity()) const;

  const TileGeometry& geometry() const { return m_geom; }
  /// Scale-aware offset for secondary rays (a fixed fraction of the tile's extent).
  double epsilon() const { return m_eps; }
  /// Triangles in the Embree scene (originals plus the periodic copies straddling the border).
  size_t embreeTriangles() const { return m_embreeTriangles; }

 private:
  template <bool kOcclusion>
  RayHit march(const DVec3& o, const DVec3& d, double tmin, double tmax) const;

  const TileGeometry& m_geom;
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  double m_eps = 1e-5;
  size_t m_embreeTriangles = 0;
};

}  // namespace btf
