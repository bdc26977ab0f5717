#include "objects.h"

#include <btf/core/error.h>
#include <btf/render/objects.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>

namespace btf::ui {

// The objects themselves live in the engine (btf/render/objects.h), shared with `btfsim render`;
// the viewer only packs them into vertex buffers.

const std::vector<std::string>& objectNames() {
  return btf::objectNames();
}

ObjectMesh makeObject(const std::string& name, int level) {
  const btf::ObjectMesh o = btf::makeObject(name, level);
  ObjectMesh m;
  m.vertices.reserve(o.pos.size());
  for (size_t k = 0; k < o.pos.size(); ++k) {
    gl::Vertex v{};
    for (int i = 0; i < 3; ++i) v.p[i] = o.pos[k][i], v.n[i] = o.nrm[k][i];
    v.uv[0] = o.uv[k].x, v.uv[1] = o.uv[k].y;
    m.vertices.push_back(v);
  }
  for (const auto& t : o.tri) m.indices.insert(m.indices.end(), {t.x, t.y, t.z});
  m.radius = o.radius;
  return m;
}

}  // namespace btf::ui
