// Scene JSON (docs/scene-format.md): parsed, written back in canonical form and parsed again (a
// fixed point), then its tile geometry built under a 64 MiB memory budget. Relative paths
// resolve in the input's private folder.
#include <btf/core/error.h>
#include <btf/geometry/tile_builder.h>
#include <btf/scene/scene.h>

#include <cmath>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "scene";

std::string cliArgs(const uint8_t* data, size_t size) {
  return "plan " + writeInput(data, size, "json");
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string path = writeInput(data, size, "json");
  const Scene s = loadScene(path);
  const std::string canon = sceneToJson(s);
  const Scene again = parseScene(canon, path + " (canonical)", inputDir());
  check(sceneToJson(again) == canon, "the canonical scene is not a fixed point of parse/write");
  const TileGeometry g = buildTileGeometry(s, uint64_t(64) << 20);
  check(!g.mesh.tri.empty(), "a tile without triangles was accepted");
  check(g.triMaterial.size() == g.mesh.tri.size(), "material ids do not match the triangles");
  for (const auto& t : g.mesh.tri)
    check(t.x < g.mesh.pos.size() && t.y < g.mesh.pos.size() && t.z < g.mesh.pos.size(),
          "a triangle index outside the vertices");
  for (const auto& p : g.mesh.pos)
    check(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z), "non-finite vertex");
}

}  // namespace btf::fuzz
