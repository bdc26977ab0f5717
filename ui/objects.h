// Base objects of the viewer, as triangle meshes with normals and BTF texture coordinates:
// analytic plane, sphere and cylinder, and subdivision surfaces refined by OpenSubdiv
// (Catmull-Clark) from the cages in resources/objects (vase, cushion, chair).
#pragma once
#include <string>
#include <vector>

#include "gl/gl.h"

namespace btf::ui {

struct ObjectMesh {
  std::vector<gl::Vertex> vertices;
  std::vector<uint32_t> indices;
  float radius = 1;  // bounding radius about the origin, for framing
};

/// An object of btf/render/objects.h ("plane", "sphere", "cylinder", "section", "hills", or a
/// cage of resources/objects: "vase", "cushion",
/// "chair"); `level` refinement levels for cages. Throws btf::Error for unknown names or a bad
/// cage (file and line).
ObjectMesh makeObject(const std::string& name, int level = 3);
const std::vector<std::string>& objectNames();

}  // namespace btf::ui
