// A checked pass over a mesh file before OpenMesh reads it. OpenMesh's readers trust their
// input: a binary PLY's element counts size its allocations and its face indices are used
// unchecked (a flipped byte is a use-after-free or a segfault), an OFF header's counts reserve
// memory. This pass reads every count, list length and vertex index with bounds from the file's
// own size, so whatever reaches OpenMesh is well formed.
#pragma once
#include <cstdint>
#include <string>

namespace btf {

struct MeshFileCounts {
  uint64_t vertices = 0, faces = 0, triangles = 0;  // triangles after fan triangulation
};

/// Validates `bytes`, the content of the mesh file `path` (the extension picks the format: .ply
/// ascii or binary of either endianness, .obj, .off ascii). Throws btf::Error naming the file,
/// the element or line and the rule; refuses a file whose faces triangulate to more than
/// `maxTriangles`. Binary OFF is refused (convert it to binary PLY).
MeshFileCounts validateMeshFile(const std::string& path, const std::string& bytes,
                                uint64_t maxTriangles);

}  // namespace btf
