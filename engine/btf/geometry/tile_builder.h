// Assembles the scene's parts into the tile's geometry: build, transform, array, material ids.
#pragma once
#include <btf/geometry/mesh.h>
#include <btf/scene/scene.h>

namespace btf {

/// Throws btf::Error naming the part when a part produces no triangles or non-finite values.
TileGeometry buildTileGeometry(const Scene& scene);

}  // namespace btf
