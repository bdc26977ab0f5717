// The periodic tracer: true periodicity, exact edges and corners, termination at grazing angles.
#include <btf/core/math.h>
#include <btf/core/rng.h>
#include <btf/geometry/tile_builder.h>
#include <btf/trace/periodic_tracer.h>
#include <gtest/gtest.h>

#include <fstream>

#include "test_util.h"

namespace btf {
namespace {

TileGeometry geometryOf(const std::string& parts, const std::string& tile = "[1, 1]") {
  return buildTileGeometry(test::sceneFromJson(
      R"({"btfscene": 1, "tile": {"size": )" + tile +
      R"(}, "materials": {"m": {"type": "lambert"}}, "parts": )" + parts + "}"));
}

TEST(PeriodicTracer, FlatPlaneIsHitAtTheRightDistanceFromAnywhere) {
  const TileGeometry g = geometryOf(R"([{"type": "plane", "material": "m", "height": 0.25}])");
  const PeriodicTracer t(g);
  Rng rng(3);
  for (int k = 0; k < 1000; ++k) {
    const double th = 0.9999 * 1.5707 * rng.uniformDouble(), ph = 2 * kPi * rng.uniformDouble();
    const DVec3 w = sphericalDir(th, ph);
    const DVec3 o(100 * rng.uniformDouble() - 50, 100 * rng.uniformDouble() - 50, 1.0);
    const RayHit h = t.intersect(o, -w);
    ASSERT_TRUE(h.hit());
    EXPECT_NEAR(h.t, 0.75 / w.z, 1e-4 / w.z);
  }
}

TEST(PeriodicTracer, SphereStraddlingTheCornerIsSeenFromAllFourCells) {
  // A sphere centred on the tile corner: its four quarters live in four cells.
  const TileGeometry g = geometryOf(
      R"([{"type": "sphere", "material": "m", "center": [0, 0, 0], "radius": 0.3, "segments": 64}])");
  const PeriodicTracer t(g);
  for (DVec3 p : {DVec3(0.1, 0.1, 0), DVec3(0.9, 0.1, 0), DVec3(0.1, 0.9, 0), DVec3(0.9, 0.9, 0),
                  DVec3(3.05, -7.05, 0)}) {
    const RayHit h = t.intersect(p + DVec3(0, 0, 2), DVec3(0, 0, -1));
    ASSERT_TRUE(h.hit()) << p.x << "," << p.y << " t=" << h.t;
    const double dx = p.x - std::round(p.x),
                 dy = p.y - std::round(p.y);  // offset to the nearest corner
    EXPECT_NEAR(2 - h.t, std::sqrt(0.09 - dx * dx - dy * dy), 2e-3);
  }
  EXPECT_FALSE(t.intersect(DVec3(0.5, 0.5, 2), DVec3(0, 0, -1)).hit());
  // Along the cell edge y = 0, which two cells share: the copy at x = 1 is hit.
  const RayHit e = t.intersect(DVec3(0.5, 0.0, 0.1), glm::normalize(DVec3(1, 0, -1e-3)));
  ASSERT_TRUE(e.hit());
  EXPECT_NEAR(0.5 + e.t, 1 - std::sqrt(0.09 - 0.01), 5e-3);
}

TEST(PeriodicTracer, RaysThroughCornersAndAlongEdgesWrapExactly) {
  // A tall thin box on the corner of every cell: rays along the diagonal pass exactly through
  // cell corners and must hit it after wrapping; rays exactly along a cell edge too.
  const TileGeometry g = geometryOf(R"([{"type": "plane", "material": "m"},
      {"type": "box", "material": "m", "center": [0.5, 0.5, 0.5], "size": [0.1, 0.1, 1.0]}])");
  const PeriodicTracer t(g);
  const DVec3 d = glm::normalize(DVec3(1, 1, -0.01));
  const RayHit h = t.intersect(DVec3(0.0, 0.0, 0.9), d);
  ASSERT_TRUE(h.hit());
  const DVec3 p = DVec3(0, 0, 0.9) + h.t * d;
  // First contact with the box face of the copy centred at (k + 0.5, k + 0.5).
  const double fx = p.x - std::floor(p.x);
  EXPECT_NEAR(fx, 0.45, 1e-4);
  // Nearly horizontal through the box's centre line: hits face x = 1.45 of the next cell's copy.
  const RayHit e = t.intersect(DVec3(0.7, 0.5, 0.5), glm::normalize(DVec3(1, 0, -1e-3)));
  ASSERT_TRUE(e.hit());
  EXPECT_NEAR(e.t, 0.75, 1e-3);
}

TEST(PeriodicTracer, GrazingRaysTerminateAndWrapMany) {
  const TileGeometry g =
      geometryOf(R"([{"type": "sine", "material": "m", "amplitude": 0.05, "periods": [3, 2]}])");
  const PeriodicTracer t(g);
  const double th = deg2rad(89.9);
  int hits = 0;
  for (int k = 0; k < 64; ++k) {
    const DVec3 w = sphericalDir(th, 2 * kPi * k / 64);
    const RayHit h = t.intersect(DVec3(0.3, 0.7, 0.2), -w);
    hits += h.hit();
    if (h.hit()) {
      EXPECT_TRUE(std::isfinite(h.t));
    }
  }
  EXPECT_EQ(hits, 64);  // a grazing ray over a closed height field always lands somewhere
  // Perfectly horizontal rays inside the slab are not traced cases: no hang, no hit.
  EXPECT_FALSE(t.intersect(DVec3(0.3, 0.7, 0.0), DVec3(1, 0, 0)).hit());
}

TEST(PeriodicTracer, ZeroAreaTrianglesAreHarmless) {
  const auto dir = test::tempDir("zero_area");
  std::ofstream(dir / "m.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  TileGeometry g = geometryOf(R"([{"type": "plane", "material": "m"}])");
  // Append a zero-area sliver and a point triangle by hand: the tracer must not crash or hit them.
  const uint32_t b = uint32_t(g.mesh.pos.size());
  g.mesh.pos.insert(g.mesh.pos.end(),
                    {Vec3(0.2f, 0.2f, 0.5f), Vec3(0.8f, 0.8f, 0.5f), Vec3(0.5f, 0.5f, 0.5f)});
  g.mesh.nrm.insert(g.mesh.nrm.end(), 3, Vec3(0, 0, 1));
  g.mesh.tri.push_back({b, b + 1, b + 2});
  g.mesh.tri.push_back({b, b, b});
  g.triMaterial.insert(g.triMaterial.end(), 2, 0);
  g.zmax = 0.5f;
  const PeriodicTracer t(g);
  const RayHit h = t.intersect(DVec3(0.5, 0.5, 1), DVec3(0, 0, -1));
  ASSERT_TRUE(h.hit());
  EXPECT_LT(h.prim, 2u);
  EXPECT_NEAR(h.t, 1.0, 1e-5);
}

}  // namespace
}  // namespace btf
