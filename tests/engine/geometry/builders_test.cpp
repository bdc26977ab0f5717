// Geometry builders: height fields sample their function exactly at vertices with the analytic
// normal, images become height fields, subdivision refines a cage, arrays and transforms place
// parts.
#include <btf/core/error.h>
#include <btf/geometry/builders.h>
#include <btf/geometry/tile_builder.h>
#include <btf/io/image_io.h>
#include <gtest/gtest.h>

#include <fstream>

#include "test_util.h"

namespace btf {
namespace {

TEST(Builders, SineHeightFieldHasExactHeightsAndAnalyticNormals) {
  const Scene s = test::sceneFromJson(
      R"({"btfscene": 1, "tile": {"size": [2, 1]}, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "sine", "material": "m", "amplitude": 0.1, "periods": [1, 0], "resolution": [64, 4]}]})");
  const TileGeometry g = buildTileGeometry(s);
  EXPECT_EQ(g.triangleCount(), 64u * 4 * 2);
  double worstN = 0;
  for (size_t k = 0; k < g.mesh.pos.size(); ++k) {
    const Vec3 p = g.mesh.pos[k];
    EXPECT_NEAR(p.z, 0.1 * std::sin(2 * kPi * p.x / 2), 1e-6);
    const double slope = 0.1 * 2 * kPi / 2 * std::cos(2 * kPi * p.x / 2);
    const DVec3 n = glm::normalize(DVec3(-slope, 0, 1));
    worstN = std::max(worstN, glm::length(n - DVec3(g.mesh.nrm[k])));
  }
  EXPECT_LT(worstN, 2e-3);  // central differences of step Δ/4
  EXPECT_NEAR(g.zmax, 0.1, 1e-6);
  EXPECT_NEAR(g.zmin, -0.1, 1e-6);
}

TEST(Builders, VGroovesAreExactlyPlanarFacets) {
  const Scene s = test::sceneFromJson(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "vgrooves", "material": "m", "count": 2, "depth": 0.25, "axis": "y"}]})");
  const TileGeometry g = buildTileGeometry(s);
  // Facet slope: depth 0.25 over a quarter tile → normals (±0.707, 0, 0.707).
  for (const Vec3& n : g.mesh.nrm) {
    EXPECT_NEAR(std::abs(n.x), std::sqrt(0.5), 1e-5);
    EXPECT_NEAR(n.z, std::sqrt(0.5), 1e-5);
  }
}

TEST(Builders, GreyImageBecomesAHeightField) {
  const auto dir = test::tempDir("image_hf");
  // 4×2 image; file row 0 is the top (v = 1). Values 0, 0.25, 0.5, 1 along x in the bottom row.
  std::vector<float> px = {0, 0, 0, 0.25f, 0.25f, 0.25f, 0.5f, 0.5f, 0.5f, 1, 1, 1,
                           0, 0, 0, 0,     0,     0,     0,    0,    0,    0, 0, 0};
  writeRgbImage((dir / "h.exr").string(), 4, 2, px);
  const Scene s = test::sceneFromJson(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "image", "material": "m", "path": "h.exr", "height": 2.0, "base": -1}]})",
                                      dir);
  const TileGeometry g = buildTileGeometry(s);
  EXPECT_EQ(g.triangleCount(), 4u * 2 * 2);
  // At the image's own resolution, vertex (i, j) takes pixel (i, j): z = base + height·value.
  EXPECT_NEAR(g.zmin, -1.0, 1e-5);
  EXPECT_NEAR(g.zmax, 1.0, 1e-5);
  int checked = 0;
  for (const Vec3& p : g.mesh.pos)
    if (std::abs(p.y) < 1e-6f && std::abs(p.x - 0.5f) < 1e-6f) {
      EXPECT_NEAR(p.z, 0.0, 1e-5);  // pixel (2, bottom row) = 0.5
      ++checked;
    }
  EXPECT_EQ(checked, 1);
  const std::string e = [&] {
    try {
      buildTileGeometry(
          test::sceneFromJson(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
        "parts": [{"type": "image", "material": "m", "path": "nope.png"}]})",
                              dir));
    } catch (const Error& x) {
      return std::string(x.what());
    }
    return std::string();
  }();
  EXPECT_NE(e.find("nope.png: height image not found"), std::string::npos) << e;
}

TEST(Builders, SubdivisionRefinesTheCageInsideItsHull) {
  const std::string cage = test::sourceDir() + "/resources/meshes/cube_cage.obj";
  for (int levels : {1, 2, 3}) {
    const TriMesh m = buildSubdivision(cage, levels, "catmark");
    EXPECT_EQ(m.tri.size(), size_t(6 * (1 << (2 * levels)) * 2));
    for (const Vec3& p : m.pos) {
      EXPECT_LE(std::abs(p.x), 0.5f + 1e-6f);
      EXPECT_LT(glm::length(p), 0.8661f);  // strictly inside the cage's corners
    }
  }
  // Catmull-Clark limit of a unit cube is a smooth blob: the face centres shrink toward ~0.42.
  const TriMesh m = buildSubdivision(cage, 4, "catmark");
  float maxX = 0;
  for (const Vec3& p : m.pos) maxX = std::max(maxX, p.x);
  EXPECT_NEAR(maxX, 0.4167f, 0.01f);
}

TEST(Builders, ArraysAndTransformsPlaceCopies) {
  const Scene s = test::sceneFromJson(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "box", "material": "m", "center": [0, 0, 0], "size": [0.1, 0.1, 0.1],
               "transform": {"scale": [1, 1, 2], "rotate": [0, 0, 90], "translate": [0.25, 0.25, 0.1]},
               "array": {"count": [2, 2], "row_shift": 0.5}}]})");
  const TileGeometry g = buildTileGeometry(s);
  EXPECT_EQ(g.triangleCount(), 4u * 12);
  EXPECT_NEAR(g.zmax, 0.2, 1e-6);
  EXPECT_NEAR(g.zmin, 0.0, 1e-6);
  // Row 1 is shifted by half the x spacing: a vertex at x = 0.25 + 0.5·0.5 ± 0.05.
  bool found = false;
  for (const Vec3& p : g.mesh.pos)
    found |= std::abs(p.x - 0.55f) < 1e-5f && std::abs(p.y - 0.8f) < 1e-5f;
  EXPECT_TRUE(found);
}

}  // namespace
}  // namespace btf

namespace btf {
namespace {

TEST(MeshFiles, OffWithCrlfLoadsAndCarriageReturnsInsideTheHeaderAreRefused) {
  const auto dir = test::tempDir("mesh_off_cr");
  const std::string crlf = (dir / "crlf.off").string(), bad = (dir / "cr.off").string();
  std::ofstream(crlf, std::ios::binary) << "OFF\r\n3 1 0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n";
  const TriMesh m = loadMeshFile(crlf, false, 100);
  EXPECT_EQ(m.pos.size(), 3u);
  EXPECT_EQ(m.tri.size(), 1u);
  // OpenMesh read other counts from such a header and reserved 9.6 GB (a fuzzer's input).
  std::ofstream(bad, std::ios::binary) << "OFF\r\r\r\r\r\r\r0 0 7   4 7\x9d";
  try {
    loadMeshFile(bad, false, 100);
    FAIL() << "carriage returns inside the header accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("a control character in the header line"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace btf
