// Assembles the scene's parts into the tile's geometry: build, transform, array, material ids.
#pragma once
#include <btf/geometry/mesh.h>
#include <btf/scene/scene.h>

#include <cstdint>

namespace btf {

/// The most triangles a tile may have (before the tracer's periodic copies): ~4 GiB of tracer,
/// maps and network at worst.
constexpr uint64_t kMaxTileTriangles = 20'000'000;

/// Throws btf::Error naming the part when a part produces no triangles or non-finite values, or
/// when its array would take the tile past kMaxTileTriangles (checked before copying).
TileGeometry buildTileGeometry(const Scene& scene);

}  // namespace btf
