// Assembles the scene's parts into the tile's geometry: build, transform, array, material ids.
#pragma once
#include <btf/geometry/mesh.h>
#include <btf/scene/scene.h>

#include <cstdint>

namespace btf {

/// What one tile triangle costs at worst, in bytes: the tracer's BVH with the periodic copies,
/// the hit maps' ids and the network's points. The memory budget divided by this bounds the
/// triangle count of a tile.
constexpr uint64_t kBytesPerTileTriangle = 200;
/// The budget of runs that name none (the simulator's default `--memory-budget`).
constexpr uint64_t kDefaultMemoryBudget = uint64_t(4) << 30;
/// The most triangles a tile may have within `memoryBudget` bytes (4 GiB: 21.5 M).
uint64_t maxTileTriangles(uint64_t memoryBudget);

/// Throws btf::Error naming the part when a part produces no triangles or non-finite values, or
/// when a part or its array would take the tile past maxTileTriangles(memoryBudget) — checked
/// before the part is built (from its declared resolution, or from its file's counts) and before
/// any copy is made.
TileGeometry buildTileGeometry(const Scene& scene, uint64_t memoryBudget = kDefaultMemoryBudget);

}  // namespace btf
