// Base objects of the renderer and the studio's viewer (docs/render.md): triangle meshes with
// smooth normals and texture coordinates — analytic plane, sphere, cylinder, a slightly curved
// cylinder section and a hilly surface (thesis figs. 4.18, 4.20), and the subdivision surfaces of
// resources/objects (vase, cushion, chair) refined by OpenSubdiv with cylindrical coordinates.
// World units, centred on the origin, z up. Texture coordinates are isotropic where the object
// allows (a square of uv maps to a square of surface), so a tile keeps its aspect.
#pragma once
#include <btf/core/math.h>

#include <string>
#include <vector>

namespace btf {

struct ObjectMesh {
  std::string name;
  std::vector<Vec3> pos, nrm;  // per vertex; normals unit
  std::vector<glm::vec2> uv;   // per vertex
  std::vector<glm::uvec3> tri;
  float radius = 1;  // bounding radius about the origin, for framing
  /// World length of one unit of uv: √(Σ world area / Σ uv area) over the triangles.
  double worldPerUv() const;
};

/// "plane", "sphere", "cylinder", "section", "hills", a cage name in resources/objects
/// ("vase", "cushion", "chair"; `level` refinements), or a mesh file (.obj, .ply, .off) with its
/// own texture coordinates, centred on the origin. Throws btf::Error for unknown names, a bad
/// file (its name and what is wrong) or a mesh without texture coordinates.
ObjectMesh makeObject(const std::string& name, int level = 3);
const std::vector<std::string>& objectNames();

}  // namespace btf
