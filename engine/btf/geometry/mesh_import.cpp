// Mesh files through OpenMesh, and subdivision surfaces through OpenSubdiv (Far, CPU).
#include <btf/core/error.h>
#include <btf/core/input_file.h>
#include <btf/geometry/builders.h>
#include <btf/geometry/mesh_validate.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <tuple>

namespace btf {

namespace {

using PolyMesh = OpenMesh::PolyMesh_ArrayKernelT<>;

/// A mesh file larger than this many bytes per allowed triangle is refused before it is read.
constexpr uint64_t kMaxMeshFileBytesPerTriangle = 16;

/// Reads a polygon mesh. The file passes our checked pass first (mesh_validate.h: counts, list
/// lengths, indices, finite vertices, the triangle bound); then OpenMesh reads it, and its
/// complaints (faces with repeated or invalid vertices) are captured and turned into one clear
/// error, and faces it had to split off because they were non-manifold are reported too.
PolyMesh readPoly(const std::string& path, uint64_t maxTriangles, bool* hasUv = nullptr) {
  const uint64_t maxBytes =
      maxTriangles > UINT64_MAX / kMaxMeshFileBytesPerTriangle
          ? UINT64_MAX
          : std::max<uint64_t>(maxTriangles * kMaxMeshFileBytesPerTriangle, 1u << 20);
  checkInputFile(path, "mesh file", maxBytes, "the memory budget's triangle bound");
  {
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in && !in.eof()) throw Error(path + ": cannot read mesh file");
    validateMeshFile(path, bytes, maxTriangles);
  }
  PolyMesh mesh;
  mesh.request_face_status();
  mesh.request_vertex_status();
  mesh.request_edge_status();
  if (hasUv) {
    mesh.request_vertex_texcoords2D();
    mesh.request_halfedge_texcoords2D();
  }
  // omerr() is a process-wide stream. It is connected once to a capture stream that lives as
  // long as the process: mostream::connect allocates a target that disconnect does not free, so
  // connecting per read leaked one per mesh (LeakSanitizer).
  static std::mutex ioMutex;
  static std::ostringstream* capture = [] {
    auto* s = new std::ostringstream;
    omerr().connect(*s);
    omerr().disconnect(std::cerr);  // its complaints become our one-line errors, not stderr text
    omlog().disable();
    return s;
  }();
  bool ok;
  std::string msgs;
  {
    std::lock_guard lock(ioMutex);
    capture->str("");
    OpenMesh::IO::Options opt;
    if (hasUv)
      opt += OpenMesh::IO::Options::VertexTexCoord, opt += OpenMesh::IO::Options::FaceTexCoord;
    ok = OpenMesh::IO::read_mesh(mesh, path, opt);
    msgs = capture->str();
    if (hasUv)
      *hasUv = opt.check(OpenMesh::IO::Options::FaceTexCoord) ||
               opt.check(OpenMesh::IO::Options::VertexTexCoord);
  }
  if (!ok) throw Error(path + ": cannot read mesh (unsupported format or malformed file)");
  if (msgs.find("equal vertices") != std::string::npos)
    throw Error(path + ": degenerate mesh: a face repeats a vertex");
  if (msgs.find("invalid vertex") != std::string::npos)
    throw Error(path + ": malformed mesh: a face refers to a vertex that does not exist");
  size_t nonManifold = 0;
  for (auto f : mesh.faces()) nonManifold += mesh.status(f).fixed_nonmanifold();
  if (nonManifold > 0)
    throw Error(
        path + ": non-manifold mesh: " + std::to_string(nonManifold) +
        " face(s) share an edge with more than one other face or are inconsistently oriented");
  if (mesh.n_faces() == 0) throw Error(path + ": mesh has no faces");
  return mesh;
}

/// The vertices, each checked finite (the file and the vertex named otherwise).
std::vector<Vec3> finitePoints(const PolyMesh& pm, const std::string& path) {
  std::vector<Vec3> out;
  out.reserve(pm.n_vertices());
  for (auto v : pm.vertices()) {
    const auto p = pm.point(v);
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      throw Error(path + ": vertex " + std::to_string(v.idx()) +
                  " has a non-finite coordinate (inf or nan)");
    out.push_back(Vec3(p[0], p[1], p[2]));
  }
  return out;
}

void checkDegenerate(const TriMesh& m, const std::string& path) {
  Vec3 lo(1e30f), hi(-1e30f);
  for (const auto& p : m.pos) {
    if (!finite3(p)) throw Error(path + ": non-finite vertex coordinate");
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const float diag = glm::length(hi - lo);
  if (!(diag > 0)) throw Error(path + ": degenerate mesh: all vertices coincide");
  for (size_t i = 0; i < m.tri.size(); ++i) {
    const auto& t = m.tri[i];
    const float a2 = glm::length(glm::cross(m.pos[t.y] - m.pos[t.x], m.pos[t.z] - m.pos[t.x]));
    if (!(a2 > 1e-10f * diag * diag))
      throw Error(path + ": degenerate mesh: triangle " + std::to_string(i) + " has zero area");
  }
}

}  // namespace

TriMesh loadMeshFile(const std::string& path, bool smooth, uint64_t maxTriangles) {
  PolyMesh pm = readPoly(path, maxTriangles);
  TriMesh m;
  m.pos = finitePoints(pm, path);
  for (auto f : pm.faces()) {
    std::vector<uint32_t> ids;
    for (auto v : pm.fv_range(f)) ids.push_back(uint32_t(v.idx()));
    for (size_t k = 1; k + 1 < ids.size(); ++k) m.tri.push_back({ids[0], ids[k], ids[k + 1]});
  }
  checkDegenerate(m, path);
  m.computeSmoothNormals();
  if (!smooth) m.makeFlat();
  return m;
}

TriMesh loadMeshFileUv(const std::string& path, std::vector<glm::vec2>* uv, uint64_t maxTriangles) {
  bool hasUv = false;
  PolyMesh pm = readPoly(path, maxTriangles, &hasUv);
  if (!hasUv)
    throw Error(path +
                ": the mesh has no texture coordinates (an OBJ's vt lines): a BTF is "
                "mapped onto an object by them");
  const bool perCorner = pm.has_halfedge_texcoords2D();
  TriMesh src;
  src.pos = finitePoints(pm, path);
  // Corners: (vertex, uv); a vertex with different uv in different faces (a seam) is split.
  std::vector<std::pair<uint32_t, glm::vec2>> corners;
  std::vector<std::vector<uint32_t>> faces;
  for (auto f : pm.faces()) {
    std::vector<uint32_t> ids;
    for (auto h : pm.fh_range(f)) {
      const auto v = pm.to_vertex_handle(h);
      const auto t = perCorner ? pm.texcoord2D(h) : pm.texcoord2D(v);
      if (!std::isfinite(t[0]) || !std::isfinite(t[1]))
        throw Error(path + ": a texture coordinate of face " + std::to_string(f.idx()) +
                    " is not finite");
      corners.push_back({uint32_t(v.idx()), glm::vec2(t[0], t[1])});
      ids.push_back(uint32_t(corners.size() - 1));
    }
    faces.push_back(ids);
  }
  for (const auto& ids : faces)
    for (size_t k = 1; k + 1 < ids.size(); ++k)
      src.tri.push_back({corners[ids[0]].first, corners[ids[k]].first, corners[ids[k + 1]].first});
  checkDegenerate(src, path);
  src.computeSmoothNormals();
  std::map<std::tuple<uint32_t, float, float>, uint32_t> split;
  TriMesh m;
  uv->clear();
  auto vertexOf = [&](uint32_t c) {
    const auto& [v, t] = corners[c];
    auto [it, fresh] = split.try_emplace({v, t.x, t.y}, uint32_t(m.pos.size()));
    if (fresh) {
      m.pos.push_back(src.pos[v]);
      m.nrm.push_back(src.nrm[v]);
      uv->push_back(t);
    }
    return it->second;
  };
  for (const auto& ids : faces)
    for (size_t k = 1; k + 1 < ids.size(); ++k)
      m.tri.push_back({vertexOf(ids[0]), vertexOf(ids[k]), vertexOf(ids[k + 1])});
  return m;
}

TriMesh buildSubdivision(const std::string& cagePath, int levels, const std::string& scheme,
                         bool sharpCorners, uint64_t maxTriangles) {
  using namespace OpenSubdiv;
  if (levels < 0 || levels > 10)
    throw Error(cagePath + ": subdivision levels must be in 0..10 (got " + std::to_string(levels) +
                ")");
  PolyMesh cage = readPoly(cagePath, maxTriangles);
  std::vector<int> vertsPerFace, faceVerts;
  for (auto f : cage.faces()) {
    int n = 0;
    for (auto v : cage.fv_range(f)) {
      faceVerts.push_back(v.idx());
      ++n;
    }
    vertsPerFace.push_back(n);
  }
  const Sdc::SchemeType type = scheme == "loop"       ? Sdc::SCHEME_LOOP
                               : scheme == "bilinear" ? Sdc::SCHEME_BILINEAR
                                                      : Sdc::SCHEME_CATMARK;
  if (type == Sdc::SCHEME_LOOP)
    for (int n : vertsPerFace)
      if (n != 3) throw Error(cagePath + ": the loop scheme needs a triangle cage");
  // The refined surface's size, before refining: loop splits a triangle into 4 per level;
  // catmark and bilinear split an n-gon into n quads, then each quad into 4 (2 triangles each).
  {
    double tris = 0;
    for (int n : vertsPerFace)
      tris += type == Sdc::SCHEME_LOOP ? std::ldexp(1.0, 2 * levels)
              : levels == 0            ? double(n - 2)
                                       : 2.0 * n * std::ldexp(1.0, 2 * (levels - 1));
    // The refiner keeps every level: about 4/3 of the last one.
    if (tris * 4 / 3 > double(maxTriangles))
      throw Error(cagePath + ": " + std::to_string(levels) + " subdivision level(s) of a " +
                  std::to_string(vertsPerFace.size()) + "-face cage make " +
                  std::to_string(uint64_t(tris)) + " triangles, more than the " +
                  std::to_string(maxTriangles) + " the memory budget allows (lower `levels`)");
  }
  Far::TopologyDescriptor desc;
  desc.numVertices = int(cage.n_vertices());
  desc.numFaces = int(vertsPerFace.size());
  desc.numVertsPerFace = vertsPerFace.data();
  desc.vertIndicesPerFace = faceVerts.data();
  Sdc::Options opts;
  opts.SetVtxBoundaryInterpolation(sharpCorners ? Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER
                                                : Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  std::unique_ptr<Far::TopologyRefiner> refiner(
      Factory::Create(desc, Factory::Options(type, opts)));
  if (!refiner) throw Error(cagePath + ": OpenSubdiv rejected the cage topology");
  refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(levels));

  struct V {
    float p[3];
    void Clear(void* = nullptr) { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(const V& s, float w) {
      p[0] += w * s.p[0];
      p[1] += w * s.p[1];
      p[2] += w * s.p[2];
    }
  };
  std::vector<V> verts(refiner->GetNumVerticesTotal());
  for (auto v : cage.vertices()) {
    const auto q = cage.point(v);
    verts[v.idx()] = V{{q[0], q[1], q[2]}};
  }
  Far::PrimvarRefiner primvar(*refiner);
  V* src = verts.data();
  for (int level = 1; level <= levels; ++level) {
    V* dst = src + refiner->GetLevel(level - 1).GetNumVertices();
    primvar.Interpolate(level, src, dst);
    src = dst;
  }
  const Far::TopologyLevel& last = refiner->GetLevel(levels);
  TriMesh m;
  for (int i = 0; i < last.GetNumVertices(); ++i)
    m.pos.push_back(Vec3(src[i].p[0], src[i].p[1], src[i].p[2]));
  for (int f = 0; f < last.GetNumFaces(); ++f) {
    Far::ConstIndexArray fv = last.GetFaceVertices(f);
    for (int k = 1; k + 1 < fv.size(); ++k)
      m.tri.push_back({uint32_t(fv[0]), uint32_t(fv[k]), uint32_t(fv[k + 1])});
  }
  m.computeSmoothNormals();
  return m;
}

}  // namespace btf
