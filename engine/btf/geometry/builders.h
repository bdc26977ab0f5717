// Geometry builders: one function per part type, each turning declared parameters into a
// TriMesh in tile coordinates (before the part's transform and array).
#pragma once
#include <btf/geometry/mesh.h>
#include <btf/scene/scene.h>

#include <functional>

namespace btf {

/// A height field z = h(x, y), periodic over the tile, on an nx × ny grid of cells.
/// Normals are the analytic-gradient of h estimated by central differences; `flat` gives faceted
/// triangles (exact planar facets for V-grooves).
TriMesh buildHeightField(double Lx, double Ly, int nx, int ny,
                         const std::function<double(double, double)>& h, bool flat);

TriMesh buildSphere(Vec3 c, float r, int segments);
TriMesh buildBox(Vec3 c, Vec3 size);
TriMesh buildCylinder(Vec3 base, float r, float h, int segments, bool caps);
TriMesh buildCone(Vec3 base, float r, float h, int segments);
TriMesh buildTorus(Vec3 c, float R, float r, int nu, int nv);

/// Mesh file (OBJ, PLY, OFF) through OpenMesh; polygons are triangulated. Throws btf::Error
/// naming the file for unreadable, empty, degenerate or non-manifold meshes.
TriMesh loadMeshFile(const std::string& path, bool smooth);
/// Subdivision surface of a control cage file, refined `levels` times by OpenSubdiv. Boundary
/// vertices interpolate their edges; `sharpCorners` also pins the corners (the object cages).
TriMesh buildSubdivision(const std::string& cagePath, int levels, const std::string& scheme,
                         bool sharpCorners = false);

/// The part's geometry (its declared type) before transform and array.
TriMesh buildPart(const Scene& scene, const PartDef& part);
/// Scale, rotate (x, y, z in degrees), translate; normals by the inverse transpose.
void applyTransform(TriMesh& m, const ParamSet& transform);

}  // namespace btf
