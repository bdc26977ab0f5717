// The shading normals of a hit, shared by every kernel that shades a hit point.
#pragma once
#include <btf/geometry/mesh.h>

namespace btf {

/// Unit geometric normal `ng` and shading normal `n` of triangle `prim` at barycentrics (u, v),
/// both flipped toward the side that `toViewer` sees (surfaces are two-sided). False for a
/// zero-area triangle, which then contributes nothing.
inline bool hitNormals(const TileGeometry& g, uint32_t prim, float u, float v, const Vec3& toViewer,
                       Vec3* ng, Vec3* n) {
  Vec3 f = g.faceNormal(prim);
  const float l = glm::length(f);
  if (!(l > 0)) return false;
  f /= l;
  Vec3 s = g.shadingNormal(prim, u, v);
  if (glm::dot(f, toViewer) < 0) {
    f = -f;
    s = -s;
  }
  *ng = f;
  *n = s;
  return true;
}

}  // namespace btf
