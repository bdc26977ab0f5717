#include "objects.h"

#include <btf/core/error.h>
#include <btf/geometry/builders.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>

namespace btf::ui {

namespace {

constexpr float kPiF = 3.14159265358979f;

void finish(ObjectMesh& m) {
  float r = 0;
  for (const auto& v : m.vertices)
    r = std::max(r, std::sqrt(v.p[0] * v.p[0] + v.p[1] * v.p[1] + v.p[2] * v.p[2]));
  m.radius = std::max(r, 1e-3f);
}

ObjectMesh grid(int nu, int nv, const std::function<void(float, float, gl::Vertex&)>& f) {
  ObjectMesh m;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      gl::Vertex v{};
      f(float(i) / nu, float(j) / nv, v);
      m.vertices.push_back(v);
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const uint32_t a = uint32_t(j * (nu + 1) + i), b = a + 1, c = a + uint32_t(nu) + 2,
                     d = a + uint32_t(nu) + 1;
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  finish(m);
  return m;
}

ObjectMesh cage(const std::string& name, int level) {
  // The engine loads and refines the cage (one mesh importer: engine/btf/geometry); the viewer
  // only centres it and gives it cylindrical texture coordinates.
  const std::string path = std::string(BTF_RESOURCE_DIR) + "/objects/" + name + ".obj";
  const TriMesh t = buildSubdivision(path, level, "catmark", true);
  ObjectMesh m;
  float zmin = 1e30f, zmax = -1e30f, cx = 0, cy = 0;
  for (size_t k = 0; k < t.pos.size(); ++k) {
    gl::Vertex g{};
    for (int i = 0; i < 3; ++i) g.p[i] = t.pos[k][i], g.n[i] = t.nrm[k][i];
    zmin = std::min(zmin, g.p[2]), zmax = std::max(zmax, g.p[2]);
    cx += g.p[0], cy += g.p[1];
    m.vertices.push_back(g);
  }
  cx /= float(m.vertices.size()), cy /= float(m.vertices.size());
  const float cz = 0.5f * (zmin + zmax), h = std::max(zmax - zmin, 1e-3f);
  for (auto& v : m.vertices) {
    v.p[0] -= cx, v.p[1] -= cy, v.p[2] -= cz;
    v.uv[0] = (std::atan2(v.p[1], v.p[0]) / (2 * kPiF)) + 0.5f;
    v.uv[1] = (v.p[2] + 0.5f * h) / h;
    const float l = std::sqrt(v.n[0] * v.n[0] + v.n[1] * v.n[1] + v.n[2] * v.n[2]);
    if (!(l > 0)) v.n[0] = v.n[1] = 0, v.n[2] = 1;
  }
  for (const auto& tr : t.tri) m.indices.insert(m.indices.end(), {tr[0], tr[1], tr[2]});
  finish(m);
  return m;
}

}  // namespace

const std::vector<std::string>& objectNames() {
  static const std::vector<std::string> n = {"plane", "sphere",  "cylinder",
                                             "vase",  "cushion", "chair"};
  return n;
}

ObjectMesh makeObject(const std::string& name, int level) {
  if (name == "plane")
    return grid(1, 1, [](float u, float v, gl::Vertex& g) {
      g.p[0] = 2 * u - 1, g.p[1] = 2 * v - 1, g.p[2] = 0;
      g.n[2] = 1;
      g.uv[0] = u, g.uv[1] = v;
    });
  if (name == "sphere")
    return grid(96, 48, [](float u, float v, gl::Vertex& g) {
      const float ph = 2 * kPiF * u, th = kPiF * (1 - v);
      g.n[0] = std::sin(th) * std::cos(ph), g.n[1] = std::sin(th) * std::sin(ph),
      g.n[2] = std::cos(th);
      for (int i = 0; i < 3; ++i) g.p[i] = g.n[i];
      g.uv[0] = u * 2, g.uv[1] = v;  // twice around so texels keep their aspect at the equator
    });
  if (name == "cylinder")
    return grid(96, 8, [](float u, float v, gl::Vertex& g) {
      const float ph = 2 * kPiF * u;
      g.n[0] = std::cos(ph), g.n[1] = std::sin(ph), g.n[2] = 0;
      g.p[0] = g.n[0] * 0.7f, g.p[1] = g.n[1] * 0.7f, g.p[2] = 2 * v - 1;
      g.uv[0] = u * 2, g.uv[1] = v * 2 / (0.7f * kPiF) * 1.0f;
    });
  for (const auto& n : objectNames())
    if (n == name) return cage(name, level);
  throw Error("unknown object '" + name +
              "' (expected plane, sphere, cylinder, vase, cushion or chair)");
}

}  // namespace btf::ui
