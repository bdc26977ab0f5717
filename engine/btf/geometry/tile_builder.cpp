#include <btf/core/error.h>
#include <btf/core/sysinfo.h>
#include <btf/geometry/builders.h>
#include <btf/geometry/tile_builder.h>

#include <algorithm>

namespace btf {

uint64_t maxTileTriangles(uint64_t memoryBudget) {
  return std::max<uint64_t>(memoryBudget / kBytesPerTileTriangle, 1024);
}

TileGeometry buildTileGeometry(const Scene& scene, uint64_t memoryBudget) {
  const uint64_t limit = maxTileTriangles(memoryBudget);
  TileGeometry g;
  g.Lx = scene.Lx;
  g.Ly = scene.Ly;
  g.zmin = 1e30f;
  g.zmax = -1e30f;
  for (size_t pi = 0; pi < scene.parts.size(); ++pi) {
    const PartDef& part = scene.parts[pi];
    const std::string where =
        scene.source + ": parts[" + std::to_string(pi) + "] ('" + part.name + "')";
    TriMesh m;
    try {
      // What is left of the budget once the parts before this one are in.
      const uint64_t used = uint64_t(g.mesh.tri.size());
      m = buildPart(scene, part, used < limit ? limit - used : 0);
    } catch (const Error& e) {
      throw Error(where + ": " + e.what());
    }
    applyTransform(m, part.transform);
    if (m.tri.empty()) throw Error(where + ": produces no triangles");
    for (const auto& p : m.pos)
      if (!finite3(p)) throw Error(where + ": has a non-finite vertex (after its transform)");
    const auto cnt = part.array.i2("count");
    // Bounded before any copy is made: the tracer, the hit maps and the network all scale with
    // the triangle count (about 200 bytes a triangle with the periodic copies in the BVH).
    const uint64_t copies = uint64_t(cnt[0]) * uint64_t(cnt[1]);
    const uint64_t total = uint64_t(g.mesh.tri.size()) + copies * uint64_t(m.tri.size());
    if (total > limit)
      throw Error(where + ": " + std::to_string(copies) + " cop" + (copies == 1 ? "y" : "ies") +
                  " of " + std::to_string(m.tri.size()) + " triangles make the tile " +
                  std::to_string(total) + " triangles, above the " + std::to_string(limit) + " a " +
                  formatBytes(double(memoryBudget)) +
                  " memory budget allows (lower the array count or the part's resolution, or "
                  "raise --memory-budget)");
    Vec2 sp = part.array.v2("spacing");
    if (sp.x == 0) sp.x = float(scene.Lx / cnt[0]);
    if (sp.y == 0) sp.y = float(scene.Ly / cnt[1]);
    const float shift = float(part.array.f("row_shift"));
    const uint16_t mat = uint16_t(scene.materialIndex(part.material));
    for (int j = 0; j < cnt[1]; ++j)
      for (int i = 0; i < cnt[0]; ++i) {
        TriMesh c = m;
        const Vec3 off(i * sp.x + ((j % 2) ? shift * sp.x : 0.f), j * sp.y, 0.f);
        for (auto& p : c.pos) p += off;
        g.mesh.append(c);
        g.triMaterial.insert(g.triMaterial.end(), c.tri.size(), mat);
        g.triPart.insert(g.triPart.end(), c.tri.size(), uint16_t(pi));
      }
  }
  for (const auto& p : g.mesh.pos) {
    if (!finite3(p)) throw Error(scene.source + ": geometry has a non-finite vertex");
    g.zmin = std::min(g.zmin, p.z);
    g.zmax = std::max(g.zmax, p.z);
  }
  for (const auto& n : g.mesh.nrm)
    if (!finite3(n)) throw Error(scene.source + ": geometry has a non-finite normal");
  return g;
}

}  // namespace btf
