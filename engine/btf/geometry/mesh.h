// Triangle meshes of the tile: what the builders produce and the tracer consumes.
#pragma once
#include <btf/core/math.h>

#include <cstdint>
#include <vector>

namespace btf {

struct TriMesh {
  std::vector<Vec3> pos;
  std::vector<Vec3> nrm;  // per-vertex shading normal (unit)
  std::vector<glm::uvec3> tri;
  void append(const TriMesh& o);
  /// Flat shading: every triangle gets its own three vertices carrying the face normal.
  void makeFlat();
  /// Shading normals as area-weighted averages of the incident face normals.
  void computeSmoothNormals();
};

/// The whole micro-geometry of one tile (periodic in x and y with periods Lx, Ly).
struct TileGeometry {
  double Lx = 1, Ly = 1;
  TriMesh mesh;
  std::vector<uint16_t> triMaterial;
  std::vector<uint16_t> triPart;
  float zmin = 0, zmax = 0;
  size_t triangleCount() const { return mesh.tri.size(); }
  /// Geometric (face) normal of a triangle, unnormalised (length = 2 × area).
  Vec3 faceNormal(uint32_t t) const;
  /// Interpolated shading normal at barycentrics (u, v) of Embree's convention.
  Vec3 shadingNormal(uint32_t t, float u, float v) const;
  Vec3 point(uint32_t t, float u, float v) const;
  uint64_t checksum() const;
};

}  // namespace btf
