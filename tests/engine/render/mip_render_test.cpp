// Texel levels in `btfsim render` (docs/mip.md): a plane at known distances selects the levels its
// footprint calls for; the sampler's trilinear lookup equals each level's own decoder at integer
// levels and stays continuous across level boundaries; silhouettes drawn with a coarse level of
// the visibility map never shrink.
#include <btf/compress/mip.h>
#include <btf/core/run_context.h>
#include <btf/geometry/tile_builder.h>
#include <btf/ops/ops.h>
#include <btf/render/objects.h>
#include <btf/render/renderer.h>
#include <btf/store/btf_store.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "test_util.h"

namespace btf {
namespace {

namespace fs = std::filesystem;

std::string simulateBumps(const fs::path& dir) {
  const fs::path scene = dir / "bumps.json";
  std::ofstream(scene) << R"({
    "btfscene": 1, "name": "bumps", "tile": {"size": [1.0, 1.0]},
    "materials": {"white": {"type": "lambert", "albedo": [0.6, 0.6, 0.6]},
                  "red": {"type": "lambert", "albedo": [0.7, 0.1, 0.1]}},
    "parts": [{"name": "ground", "type": "plane", "material": "red"},
              {"name": "b", "type": "bumps", "material": "white", "count": [2, 2],
               "radius": 0.3, "height": 0.25, "resolution": [32, 32]}],
    "simulation": {"texels": [16, 16], "directions": "axis-grid", "grid": [6, 16]}
  })";
  const std::string out = (dir / "bumps.btf").string();
  RunContext ctx;
  ctx.progress = false;
  ops::run(ops::Request("simulate")
               .set("scene", scene.string())
               .set("output", out)
               .set("bounces", "1")
               .setFlag("quiet", true),
           ctx);
  return out;
}

const std::string& bumps() {
  static const std::string path = simulateBumps(test::tempDir("mip_render"));
  return path;
}

TileGeometry bumpsTile() {
  BtfReader r(bumps());
  return buildTileGeometry(parseScene(r.info().sceneJson, bumps(), ""));
}

TEST(MipRender, APlaneAtKnownDistancesSelectsTheExpectedLevels) {
  const TileGeometry tile = bumpsTile();
  BtfSampler btf(bumps(), "", false, uint64_t(1) << 30, nullptr, true);
  ASSERT_EQ(btf.levels(), 5);  // 16² … 1²
  const ObjectMesh plane = makeObject("plane");
  // Straight down, orthographic: a pixel is 2·1.05·R/(zoom·H) world units; a texel is
  // 2/(tiling·16). Footprints of 2, 4, 8 and 16 texels a side are cut in 2 × 2 cells of 1, 2,
  // 4 and 8 texels: levels 0, 1, 2, 3.
  const int H = 32;
  const double tiling = 2;
  for (int expect = 0; expect <= 3; ++expect) {
    const double side = 2.0 * std::pow(2.0, expect);  // texels per pixel
    RenderSettings s;
    s.width = s.height = H;
    s.spp = 1;
    s.camTheta = 0, s.camPhi = 0;
    s.tiling = tiling;
    s.zoom = (2 * 1.05 * plane.radius / H) / (side * 2 / (tiling * 16));
    const RenderScene rs(plane, tile.Lx, tile.Ly, tile.zmin, tile.zmax, s);
    for (const RenderImage& img :
         {rs.renderFlat(btf, nullptr, nullptr), rs.renderMapped(btf, nullptr, nullptr)}) {
      SCOPED_TRACE(img.mode + " level " + std::to_string(expect));
      const size_t centre = size_t(H / 2) * size_t(H) + size_t(H / 2);
      ASSERT_GT(img.alpha[centre], 0.5f);
      EXPECT_NEAR(img.lod[centre], expect, 1e-3);
      EXPECT_NEAR(img.footprintTexels[centre], side * side, 1e-3 * side * side);
    }
  }
  // Nearer than one texel per pixel: level 0, one tap.
  RenderSettings s;
  s.width = s.height = H;
  s.spp = 1;
  s.camTheta = 0;
  s.tiling = tiling;
  s.zoom = (2 * 1.05 * plane.radius / H) / (0.25 * 2 / (tiling * 16));
  const RenderScene near(plane, tile.Lx, tile.Ly, tile.zmin, tile.zmax, s);
  const RenderImage img = near.renderFlat(btf, nullptr, nullptr);
  EXPECT_EQ(img.lod[size_t(H / 2) * size_t(H) + size_t(H / 2)], 0.f);
}

TEST(MipRender, OneFilteredSampleApproachesTheSupersampledPixel) {
  // A tiled plane where a pixel covers ~30 texels: at 1 sample per pixel the levels' box
  // averages stand in for the 64 samples a supersampled pixel averages; point sampling cannot.
  const TileGeometry tile = bumpsTile();
  BtfSampler btf(bumps(), "", false, uint64_t(1) << 30, nullptr, true);
  RenderSettings s;
  s.width = s.height = 40;
  s.camTheta = 35, s.camPhi = -90;
  s.tiling = 8;
  auto render = [&](bool mip, int spp) {
    RenderSettings t = s;
    t.mip = mip;
    t.spp = spp;
    const RenderScene rs(makeObject("plane"), tile.Lx, tile.Ly, tile.zmin, tile.zmax, t);
    return rs.renderFlat(btf, nullptr, nullptr);
  };
  const RenderImage ref = render(false, 64), point = render(false, 1), mip = render(true, 1);
  size_t any = 0;
  for (size_t p = 0; p < mip.lod.size(); ++p) any += mip.lod[p] > 0.5f;
  EXPECT_GT(any, mip.lod.size() / 4);  // coarse levels were used
  const ImageError ep = compareImages(point, ref), em = compareImages(mip, ref);
  EXPECT_GT(em.interiorPixels, 400);
  EXPECT_LT(em.relRmseInterior, 0.10);
  EXPECT_LT(em.relRmseInterior, 0.5 * ep.relRmseInterior)
      << "mip " << em.relRmseInterior << " point " << ep.relRmseInterior;
}

TEST(MipRender, TrilinearLookupsMatchEachLevelAndAreContinuousAcrossLevels) {
  BtfSampler btf(bumps(), "", false, uint64_t(1) << 30, nullptr, true);
  const DVec3 wo = glm::normalize(DVec3(0.3, -0.2, 0.9)),
              wi = glm::normalize(DVec3(-0.4, 0.1, 0.8));
  const double x = 0.37, y = 0.61;  // tile units (Lx = 1)
  // At an integer level with one tap: that level's own box-filtered texels, bilinear.
  for (int k = 0; k < btf.levels(); ++k) {
    const auto level = openBtfLevel(bumps(), k);
    BtfSampler::Footprint fp;
    fp.lod = k;
    const Rgb got = btf.eval(x, y, wo, wi, &fp);
    const double thO = std::acos(wo.z), phO = std::atan2(wo.y, wo.x);
    const double thI = std::acos(wi.z), phI = std::atan2(wi.y, wi.x);
    const auto want =
        level->evaluateAt(x * level->info().nu, y * level->info().nv, thI, phI, thO, phO);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(got[c], want[size_t(c)], 1e-5 * (1 + want[size_t(c)])) << "level " << k;
  }
  // Continuous in lod: no jump at the level boundaries, small steps everywhere.
  BtfSampler::Footprint fp;
  fp.a = {0.05, 0.01}, fp.b = {-0.02, 0.06};
  fp.na = 2, fp.nb = 2;
  double scale = 0;
  for (double l = 0; l <= 4; l += 0.5) {
    fp.lod = l;
    scale = std::max(scale, double(btf.eval(x, y, wo, wi, &fp).x));
  }
  ASSERT_GT(scale, 0);
  for (int k = 1; k < btf.levels(); ++k) {
    fp.lod = k - 1e-7;
    const Rgb below = btf.eval(x, y, wo, wi, &fp);
    fp.lod = k + 1e-7;
    const Rgb above = btf.eval(x, y, wo, wi, &fp);
    EXPECT_NEAR(below.x, above.x, 1e-5 * scale) << "at level " << k;
  }
  Rgb prev(0);
  for (int i = 0; i <= 400; ++i) {
    fp.lod = 4.0 * i / 400;
    const Rgb v = btf.eval(x, y, wo, wi, &fp);
    if (i) {
      EXPECT_LT(std::abs(v.x - prev.x), 0.05 * scale) << "lod " << fp.lod;
    }
    prev = v;
  }
}

TEST(MipRender, CoarseVisibilityLevelsNeverShrinkTheSilhouette) {
  const TileGeometry tile = bumpsTile();
  BtfSampler btf(bumps(), "", false, uint64_t(1) << 30, nullptr, true);
  // A sphere seen from the side with tall relief: grazing rays over the silhouette.
  RenderSettings s;
  s.width = s.height = 64;
  s.spp = 1;
  s.camTheta = 80, s.camPhi = -90;
  s.tiling = 2;
  s.reliefScale = 3;
  int64_t base = -1;
  std::vector<float> baseAlpha;
  for (int k = 0; k < btf.levels(); ++k) {
    s.forceLevel = k;
    const RenderScene rs(makeObject("sphere"), tile.Lx, tile.Ly, tile.zmin, tile.zmax, s);
    const RenderImage img = rs.renderMapped(btf, nullptr, nullptr);
    int64_t n = 0, lost = 0;
    for (size_t p = 0; p < img.alpha.size(); ++p) {
      n += img.alpha[p] >= 0.5f;
      if (k > 0) lost += baseAlpha[p] >= 0.5f && img.alpha[p] < 0.5f;
    }
    if (k == 0) {
      base = n;
      baseAlpha = img.alpha;
      continue;
    }
    SCOPED_TRACE("level " + std::to_string(k));
    EXPECT_GE(n, base);
    EXPECT_EQ(lost, 0);
  }
}

}  // namespace
}  // namespace btf
