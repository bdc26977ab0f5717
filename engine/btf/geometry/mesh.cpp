#include <btf/core/hash.h>
#include <btf/geometry/mesh.h>

namespace btf {

void TriMesh::append(const TriMesh& o) {
  const uint32_t base = uint32_t(pos.size());
  pos.insert(pos.end(), o.pos.begin(), o.pos.end());
  nrm.insert(nrm.end(), o.nrm.begin(), o.nrm.end());
  for (auto t : o.tri) tri.push_back(t + glm::uvec3(base));
}

void TriMesh::makeFlat() {
  TriMesh f;
  for (auto t : tri) {
    Vec3 a = pos[t.x], b = pos[t.y], c = pos[t.z];
    Vec3 n = glm::cross(b - a, c - a);
    const float l = glm::length(n);
    n = l > 0 ? n / l : Vec3(0, 0, 1);
    const uint32_t k = uint32_t(f.pos.size());
    f.pos.insert(f.pos.end(), {a, b, c});
    f.nrm.insert(f.nrm.end(), {n, n, n});
    f.tri.push_back({k, k + 1, k + 2});
  }
  *this = std::move(f);
}

void TriMesh::computeSmoothNormals() {
  nrm.assign(pos.size(), Vec3(0));
  for (auto t : tri) {
    Vec3 n = glm::cross(pos[t.y] - pos[t.x], pos[t.z] - pos[t.x]);
    nrm[t.x] += n;
    nrm[t.y] += n;
    nrm[t.z] += n;
  }
  for (auto& n : nrm) {
    const float l = glm::length(n);
    n = l > 0 ? n / l : Vec3(0, 0, 1);
  }
}

Vec3 TileGeometry::faceNormal(uint32_t t) const {
  const auto& i = mesh.tri[t];
  return glm::cross(mesh.pos[i.y] - mesh.pos[i.x], mesh.pos[i.z] - mesh.pos[i.x]);
}

Vec3 TileGeometry::shadingNormal(uint32_t t, float u, float v) const {
  const auto& i = mesh.tri[t];
  Vec3 n = (1 - u - v) * mesh.nrm[i.x] + u * mesh.nrm[i.y] + v * mesh.nrm[i.z];
  const float l = glm::length(n);
  if (l > 1e-12f) return n / l;
  n = faceNormal(t);
  const float lf = glm::length(n);
  return lf > 0 ? n / lf : Vec3(0, 0, 1);
}

Vec3 TileGeometry::point(uint32_t t, float u, float v) const {
  const auto& i = mesh.tri[t];
  return (1 - u - v) * mesh.pos[i.x] + u * mesh.pos[i.y] + v * mesh.pos[i.z];
}

uint64_t TileGeometry::checksum() const {
  uint64_t h = checksum64(mesh.pos.data(), mesh.pos.size() * sizeof(Vec3));
  h = checksum64(mesh.nrm.data(), mesh.nrm.size() * sizeof(Vec3), h);
  h = checksum64(mesh.tri.data(), mesh.tri.size() * sizeof(glm::uvec3), h);
  h = checksum64(triMaterial.data(), triMaterial.size() * 2, h);
  const double L[2] = {Lx, Ly};
  return checksum64(L, sizeof L, h);
}

}  // namespace btf
