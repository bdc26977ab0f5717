// Geometry builders: one function per part type, each turning declared parameters into a
// TriMesh in tile coordinates (before the part's transform and array).
#pragma once
#include <btf/geometry/mesh.h>
#include <btf/scene/scene.h>

#include <cstdint>
#include <functional>
#include <vector>

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

/// No bound on a part's triangles beyond what the caller checks afterwards.
constexpr uint64_t kNoTriangleBound = uint64_t(1) << 40;

/// Mesh file (OBJ, PLY, OFF) through OpenMesh after a checked pass (mesh_validate.h); polygons
/// are triangulated. Throws btf::Error naming the file for unreadable, malformed, empty,
/// degenerate or non-manifold meshes, and for meshes past `maxTriangles` (before OpenMesh
/// reads them).
TriMesh loadMeshFile(const std::string& path, bool smooth,
                     uint64_t maxTriangles = kNoTriangleBound);
/// A mesh file with texture coordinates (an object to render a BTF on): as loadMeshFile, smooth
/// normals, vertices split where a face gives them other texture coordinates (seams); `uv` per
/// vertex. Throws btf::Error naming the file when it has no texture coordinates.
TriMesh loadMeshFileUv(const std::string& path, std::vector<glm::vec2>* uv,
                       uint64_t maxTriangles = kNoTriangleBound);
/// Subdivision surface of a control cage file, refined `levels` times by OpenSubdiv. Boundary
/// vertices interpolate their edges; `sharpCorners` also pins the corners (the object cages).
/// The refined size is checked against `maxTriangles` before refining.
TriMesh buildSubdivision(const std::string& cagePath, int levels, const std::string& scheme,
                         bool sharpCorners = false, uint64_t maxTriangles = kNoTriangleBound);

/// The part's geometry (its declared type) before transform and array. Throws btf::Error before
/// building when the part would have more than `maxTriangles` triangles (from its declared
/// resolution or segments, an image's size, a mesh file's counts, a cage's refined size).
TriMesh buildPart(const Scene& scene, const PartDef& part,
                  uint64_t maxTriangles = kNoTriangleBound);
/// Reads a height image's first channel (OpenImageIO), row 0 at v = 1; refuses images of more
/// than `maxPixels` pixels before decoding them, and non-finite values.
std::vector<float> readHeightImage(const std::string& path, uint64_t maxPixels, int* width,
                                   int* height);
/// Scale, rotate (x, y, z in degrees), translate; normals by the inverse transpose.
void applyTransform(TriMesh& m, const ParamSet& transform);

}  // namespace btf
