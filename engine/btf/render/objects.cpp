#include <btf/core/error.h>
#include <btf/geometry/builders.h>
#include <btf/render/objects.h>

#include <cmath>
#include <filesystem>
#include <functional>

namespace btf {

namespace {

void finish(ObjectMesh& m) {
  float r = 0;
  for (const auto& p : m.pos) r = std::max(r, glm::length(p));
  m.radius = std::max(r, 1e-3f);
}

/// (nu + 1) × (nv + 1) vertices from f(s, t) with s, t in [0, 1]; two triangles per cell.
ObjectMesh grid(const std::string& name, int nu, int nv,
                const std::function<void(float, float, Vec3&, Vec3&, glm::vec2&)>& f) {
  ObjectMesh m;
  m.name = name;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      Vec3 p, n;
      glm::vec2 uv;
      f(float(i) / float(nu), float(j) / float(nv), p, n, uv);
      m.pos.push_back(p);
      m.nrm.push_back(glm::normalize(n));
      m.uv.push_back(uv);
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const uint32_t a = uint32_t(j * (nu + 1) + i), b = a + 1, c = a + uint32_t(nu) + 2,
                     d = a + uint32_t(nu) + 1;
      m.tri.push_back({a, b, c});
      m.tri.push_back({a, c, d});
    }
  finish(m);
  return m;
}

ObjectMesh cage(const std::string& name, int level) {
  // The engine's importer loads and refines the cage; here it is centred and given cylindrical
  // texture coordinates (u around the axis, v up, both in units of the circumference's scale).
  const std::string path = std::string(BTF_RESOURCE_DIR) + "/objects/" + name + ".obj";
  const TriMesh t = buildSubdivision(path, level, "catmark", true);
  ObjectMesh m;
  m.name = name;
  float zmin = 1e30f, zmax = -1e30f;
  Vec3 c(0);
  for (const auto& p : t.pos) {
    zmin = std::min(zmin, p.z), zmax = std::max(zmax, p.z);
    c += p;
  }
  c /= float(std::max<size_t>(t.pos.size(), 1));
  c.z = 0.5f * (zmin + zmax);
  float meanR = 0;
  for (const auto& p : t.pos) meanR += std::hypot(p.x - c.x, p.y - c.y);
  meanR = std::max(meanR / float(std::max<size_t>(t.pos.size(), 1)), 1e-3f);
  for (size_t k = 0; k < t.pos.size(); ++k) {
    const Vec3 p = t.pos[k] - c;
    Vec3 n = t.nrm[k];
    if (!(glm::length(n) > 0)) n = Vec3(0, 0, 1);
    m.pos.push_back(p);
    m.nrm.push_back(glm::normalize(n));
    // u: one unit per turn; v scaled so that a unit of v is a turn's length at the mean radius.
    m.uv.push_back({std::atan2(p.y, p.x) / (2 * kPiF) + 0.5f, p.z / (2 * kPiF * meanR)});
  }
  // Triangles across the seam (u jumps by ~1) get their own copies of the low-u vertices, moved
  // by one turn: with an integer tiling the tile continues across the seam.
  for (const auto& tr : t.tri) {
    glm::uvec3 q = tr;
    const float u0 = m.uv[q.x].x, u1 = m.uv[q.y].x, u2 = m.uv[q.z].x;
    const float hi = std::max({u0, u1, u2});
    if (hi - std::min({u0, u1, u2}) > 0.5f)
      for (int i = 0; i < 3; ++i)
        if (m.uv[q[i]].x < hi - 0.5f) {
          m.pos.push_back(m.pos[q[i]]);
          m.nrm.push_back(m.nrm[q[i]]);
          m.uv.push_back(m.uv[q[i]] + glm::vec2(1, 0));
          q[i] = uint32_t(m.pos.size() - 1);
        }
    m.tri.push_back(q);
  }
  // Where the cylindrical map degenerates (caps, faces in a plane through the axis: its uv area
  // all but vanishes), the triangle's vertices get their own copies mapped by a planar
  // projection along the face normal's largest axis (same scale): a seam there, but a texture
  // map on every triangle.
  const size_t nTri = m.tri.size();
  for (size_t k = 0; k < nTri; ++k) {
    glm::uvec3& q = m.tri[k];
    const Vec3 a = m.pos[q.x], b = m.pos[q.y], c = m.pos[q.z];
    const Vec3 fn = glm::cross(b - a, c - a);
    const float aw = 0.5f * glm::length(fn);
    const glm::vec2 e1 = m.uv[q.y] - m.uv[q.x], e2 = m.uv[q.z] - m.uv[q.x];
    const float at =
        0.5f * std::abs(e1.x * e2.y - e1.y * e2.x) * (2 * kPiF * meanR) * (2 * kPiF * meanR);
    if (!(aw > 0) || at > 0.25f * aw) continue;
    for (int i = 0; i < 3; ++i) {
      m.pos.push_back(m.pos[q[i]]);
      m.nrm.push_back(m.nrm[q[i]]);
      const Vec3 p = m.pos[q[i]] / (2 * kPiF * meanR);
      const Vec3 an = glm::abs(fn);
      m.uv.push_back(an.z >= an.x && an.z >= an.y ? glm::vec2(p.x, p.y)
                     : an.x >= an.y               ? glm::vec2(p.y, p.z)
                                                  : glm::vec2(p.x, p.z));
      q[i] = uint32_t(m.pos.size() - 1);
    }
  }
  finish(m);
  return m;
}

}  // namespace

double ObjectMesh::worldPerUv() const {
  double aw = 0, at = 0;
  for (const auto& t : tri) {
    aw += 0.5 * glm::length(glm::cross(DVec3(pos[t.y] - pos[t.x]), DVec3(pos[t.z] - pos[t.x])));
    const glm::dvec2 e1 = glm::dvec2(uv[t.y] - uv[t.x]), e2 = glm::dvec2(uv[t.z] - uv[t.x]);
    at += 0.5 * std::abs(e1.x * e2.y - e1.y * e2.x);
  }
  return at > 0 ? std::sqrt(aw / at) : 1.0;
}

const std::vector<std::string>& objectNames() {
  static const std::vector<std::string> n = {"plane", "sphere", "cylinder", "section",
                                             "hills", "vase",   "cushion",  "chair"};
  return n;
}

ObjectMesh makeObject(const std::string& name, int level) {
  if (name == "plane")  // [-1, 1]², facing +z; one uv unit = 2 world units
    return grid(name, 1, 1, [](float s, float t, Vec3& p, Vec3& n, glm::vec2& uv) {
      p = {2 * s - 1, 2 * t - 1, 0}, n = {0, 0, 1}, uv = {s, t};
    });
  if (name == "sphere")  // unit sphere; u twice around so texels keep their aspect at the equator
    return grid(name, 128, 64, [](float s, float t, Vec3& p, Vec3& n, glm::vec2& uv) {
      const float ph = 2 * kPiF * s, th = kPiF * (1 - t);
      n = {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
      p = n, uv = {2 * s, t};
    });
  if (name == "cylinder")  // radius 0.7, height 2, axis z, no caps
    return grid(name, 128, 16, [](float s, float t, Vec3& p, Vec3& n, glm::vec2& uv) {
      const float ph = 2 * kPiF * s;
      n = {std::cos(ph), std::sin(ph), 0};
      p = {0.7f * n.x, 0.7f * n.y, 2 * t - 1};
      uv = {2 * s, t * 2 / (0.7f * kPiF)};
    });
  if (name == "section")  // radius 2, 90° of arc about the y axis, 2 long, bulging toward +z
    return grid(name, 96, 48, [](float s, float t, Vec3& p, Vec3& n, glm::vec2& uv) {
      const float R = 2, a = (s - 0.5f) * 0.5f * kPiF;
      n = {std::sin(a), 0, std::cos(a)};
      p = {R * n.x, 2 * t - 1, R * n.z - R * 0.85f};
      uv = {s * R * 0.5f * kPiF / 2, t};  // one uv unit = 2 world units both ways
    });
  if (name == "hills")  // [-1, 1]² with z = 0.12 sin(πx) sin(πy): hills and hollows
    return grid(name, 96, 96, [](float s, float t, Vec3& p, Vec3& n, glm::vec2& uv) {
      const float x = 2 * s - 1, y = 2 * t - 1, A = 0.12f;
      p = {x, y, A * std::sin(kPiF * x) * std::sin(kPiF * y)};
      n = {-A * kPiF * std::cos(kPiF * x) * std::sin(kPiF * y),
           -A * kPiF * std::sin(kPiF * x) * std::cos(kPiF * y), 1};
      uv = {s, t};
    });
  for (const auto& n : objectNames())
    if (n == name) return cage(name, level);
  const std::string ext = std::filesystem::path(name).extension().string();
  if (ext == ".obj" || ext == ".OBJ" || ext == ".ply" || ext == ".off") {
    // A user's mesh with its own texture coordinates, centred on the origin.
    ObjectMesh m;
    m.name = std::filesystem::path(name).filename().string();
    const TriMesh t = loadMeshFileUv(name, &m.uv, uint64_t(1) << 24);
    Vec3 lo(1e30f), hi(-1e30f);
    for (const auto& p : t.pos) lo = glm::min(lo, p), hi = glm::max(hi, p);
    const Vec3 c = 0.5f * (lo + hi);
    for (size_t k = 0; k < t.pos.size(); ++k) {
      m.pos.push_back(t.pos[k] - c);
      m.nrm.push_back(glm::length(t.nrm[k]) > 0 ? glm::normalize(t.nrm[k]) : Vec3(0, 0, 1));
    }
    m.tri = t.tri;
    finish(m);
    return m;
  }
  throw Error("unknown object '" + name +
              "' (expected plane, sphere, cylinder, section, hills, vase, cushion, chair, or a "
              "mesh file with texture coordinates: .obj, .ply, .off)");
}

}  // namespace btf
