#include "objects.h"

#include <btf/core/error.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>

namespace btf::ui {

namespace {

constexpr float kPiF = 3.14159265358979f;

struct P3 {
  float x = 0, y = 0, z = 0;
  void Clear(void* = nullptr) { x = y = z = 0; }
  void AddWithWeight(const P3& s, float w) {
    x += w * s.x;
    y += w * s.y;
    z += w * s.z;
  }
};

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
  const std::string path = std::string(BTF_RESOURCE_DIR) + "/objects/" + name + ".obj";
  std::ifstream f(path);
  if (!f) throw Error(path + ": cannot open the object's cage");
  std::vector<P3> pos;
  std::vector<int> counts, idx;
  std::string line;
  for (int ln = 1; std::getline(f, line); ++ln) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      P3 p;
      if (!(s >> p.x >> p.y >> p.z)) throw Error(path + ":" + std::to_string(ln) + ": bad vertex");
      pos.push_back(p);
    } else if (tag == "f") {
      std::string t;
      int n = 0;
      while (s >> t) {
        const int k = std::stoi(t.substr(0, t.find('/'))) - 1;
        if (k < 0 || k >= int(pos.size()))
          throw Error(path + ":" + std::to_string(ln) + ": vertex index out of range");
        idx.push_back(k);
        ++n;
      }
      if (n < 3) throw Error(path + ":" + std::to_string(ln) + ": a face needs 3 vertices");
      counts.push_back(n);
    }
  }
  using namespace OpenSubdiv;
  Far::TopologyDescriptor desc;
  desc.numVertices = int(pos.size());
  desc.numFaces = int(counts.size());
  desc.numVertsPerFace = counts.data();
  desc.vertIndicesPerFace = idx.data();
  Sdc::Options opts;
  opts.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  std::unique_ptr<Far::TopologyRefiner> refiner(
      Factory::Create(desc, Factory::Options(Sdc::SCHEME_CATMARK, opts)));
  if (!refiner) throw Error(path + ": OpenSubdiv cannot build the cage's topology");
  refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(level));
  std::vector<P3> buf(size_t(refiner->GetNumVerticesTotal()));
  std::copy(pos.begin(), pos.end(), buf.begin());
  Far::PrimvarRefiner pr(*refiner);
  P3* src = buf.data();
  for (int l = 1; l <= level; ++l) {
    P3* dst = src + refiner->GetLevel(l - 1).GetNumVertices();
    pr.Interpolate(l, src, dst);
    src = dst;
  }
  const Far::TopologyLevel& last = refiner->GetLevel(level);
  ObjectMesh m;
  float zmin = 1e30f, zmax = -1e30f;
  for (int v = 0; v < last.GetNumVertices(); ++v) {
    gl::Vertex g{};
    g.p[0] = src[v].x, g.p[1] = src[v].y, g.p[2] = src[v].z;
    zmin = std::min(zmin, g.p[2]), zmax = std::max(zmax, g.p[2]);
    m.vertices.push_back(g);
  }
  // Centre on the origin; normals from the refined faces; cylindrical texture coordinates.
  float cx = 0, cy = 0;
  for (auto& v : m.vertices) cx += v.p[0], cy += v.p[1];
  cx /= float(m.vertices.size()), cy /= float(m.vertices.size());
  const float cz = 0.5f * (zmin + zmax), h = std::max(zmax - zmin, 1e-3f);
  for (auto& v : m.vertices) {
    v.p[0] -= cx, v.p[1] -= cy, v.p[2] -= cz;
    v.uv[0] = (std::atan2(v.p[1], v.p[0]) / (2 * kPiF)) + 0.5f;
    v.uv[1] = (v.p[2] + 0.5f * h) / h;
  }
  for (int fc = 0; fc < last.GetNumFaces(); ++fc) {
    const auto fv = last.GetFaceVertices(fc);
    for (int k = 1; k + 1 < fv.size(); ++k) {
      const uint32_t a = uint32_t(fv[0]), b = uint32_t(fv[k]), c = uint32_t(fv[k + 1]);
      m.indices.insert(m.indices.end(), {a, b, c});
      const float* pa = m.vertices[a].p;
      const float* pb = m.vertices[b].p;
      const float* pc = m.vertices[c].p;
      const float e1[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
      const float e2[3] = {pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
      const float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                          e1[0] * e2[1] - e1[1] * e2[0]};
      for (uint32_t q : {a, b, c})
        for (int i = 0; i < 3; ++i) m.vertices[q].n[i] += n[i];
    }
  }
  for (auto& v : m.vertices) {
    const float l = std::sqrt(v.n[0] * v.n[0] + v.n[1] * v.n[1] + v.n[2] * v.n[2]);
    for (float& x : v.n) x = l > 0 ? x / l : 0;
    if (l == 0) v.n[2] = 1;
  }
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
