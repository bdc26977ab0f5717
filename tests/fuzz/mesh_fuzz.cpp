// Mesh files (OBJ, PLY ascii/binary, OFF): the first byte picks the extension, the rest is the
// file. Read as a mesh part (200 000-triangle bound) and, when that succeeds, as an object with
// texture coordinates and as a one-level Catmull-Clark cage.
#include <btf/core/error.h>
#include <btf/geometry/builders.h>

#include <cmath>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "mesh";

namespace {
void checkMesh(const TriMesh& m) {
  check(!m.tri.empty(), "a mesh without triangles was accepted");
  for (const auto& t : m.tri)
    check(t.x < m.pos.size() && t.y < m.pos.size() && t.z < m.pos.size(),
          "a triangle index outside the vertices");
  for (const auto& p : m.pos)
    check(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z), "non-finite vertex");
  for (const auto& n : m.nrm)
    check(std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z), "non-finite normal");
}
}  // namespace

std::string writeMesh(const uint8_t* data, size_t size) {
  if (size < 1) throw Error(inputDir() + "/input: empty fuzz input");
  static const char* const exts[] = {"obj", "ply", "off"};
  return writeInput(data + 1, size - 1, exts[data[0] % 3]);
}

std::string cliArgs(const uint8_t* data, size_t size) {
  return "plan " + sceneWithFile("mesh", "path", writeMesh(data, size));
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string path = writeMesh(data, size);
  constexpr uint64_t kMaxTriangles = 200000;
  checkMesh(loadMeshFile(path, true, kMaxTriangles));
  // As an object to render on (btfsim render --object FILE): its texture coordinates, when it
  // has them (a mesh without is refused with its own message, a clean refusal too).
  try {
    std::vector<glm::vec2> uv;
    const TriMesh m = loadMeshFileUv(path, &uv, kMaxTriangles);
    checkMesh(m);
    check(uv.size() == m.pos.size(), "texture coordinates and vertices differ in count");
    for (const auto& t : uv) check(std::isfinite(t.x) && std::isfinite(t.y), "non-finite uv");
  } catch (const Error&) {
  }
  checkMesh(buildSubdivision(path, 1, "catmark", false, kMaxTriangles));
}

}  // namespace btf::fuzz
