// btfsim render (docs/render.md): the flat, mapped and exact modes against analytic values and
// each other — a flat tile is the same in all three, V-grooves at grazing angles show their
// analytic masking, the shell's silhouette matches the exact micro-geometry's, a tall relief's
// shadow reaches its neighbours, a non-height-field tile on a curved section stays within the
// stated tolerance — and bad input gets a clear message.
#include <btf/core/error.h>
#include <btf/core/run_context.h>
#include <btf/geometry/tile_builder.h>
#include <btf/io/image_io.h>
#include <btf/ops/ops.h>
#include <btf/render/objects.h>
#include <btf/render/renderer.h>
#include <btf/scene/material.h>
#include <btf/store/btf_store.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "test_util.h"

namespace btf {
namespace {

namespace fs = std::filesystem;

using test::errorOf;

RunContext quiet() {
  RunContext ctx;
  ctx.progress = false;
  return ctx;
}

/// Writes the scene JSON and simulates it into DIR/NAME.btf (small, direct settings).
std::string simulate(const fs::path& dir, const std::string& name, const std::string& json,
                     const std::vector<std::pair<std::string, std::string>>& opts = {}) {
  const fs::path scene = dir / (name + ".json");
  std::ofstream(scene) << json;
  const std::string out = (dir / (name + ".btf")).string();
  ops::Request r("simulate");
  r.set("scene", scene.string()).set("output", out);
  for (const auto& [k, v] : opts) r.set(k, v);
  r.setFlag("quiet", true);
  ops::run(r, quiet());
  return out;
}

struct Tile {
  Scene scene;
  TileGeometry geom;
};
Tile tileOf(const std::string& btfPath) {
  BtfReader reader(btfPath);
  Tile t;
  t.scene = parseScene(reader.info().sceneJson, btfPath, fs::path(btfPath).parent_path());
  t.geom = buildTileGeometry(t.scene);
  return t;
}

/// Mean grey over the pixels at least `minAlpha` covered whose neighbours `margin` pixels away
/// (rows and columns) are fully covered too: away from the object's edges.
/// The three modes of one BTF on `object` (the sky's table prepared when the settings ask for
/// one).
struct Images {
  RenderImage flat, mapped, exact;
};
Images renderAll(const std::string& btfPath, const std::string& object, const RenderSettings& s,
                 bool flatTile = false) {
  const Tile t = tileOf(btfPath);
  const RenderScene rs(makeObject(object), 1, 1, t.geom.zmin, t.geom.zmax, s);
  BtfSampler btf(btfPath, "", flatTile, uint64_t(1) << 30);
  if (s.environment > 0) btf.prepareAmbient();
  Images im;
  im.flat = rs.renderFlat(btf, nullptr, nullptr);
  im.mapped = rs.renderMapped(btf, nullptr, nullptr);
  im.exact = rs.renderExact(t.geom, compileMaterials(t.scene), uint64_t(1) << 24, nullptr, nullptr);
  return im;
}

double meanOver(const RenderImage& img, float minAlpha = 0.999f, int margin = 0) {
  double s = 0;
  int64_t n = 0;
  auto full = [&](int i, int j) {
    return i >= 0 && j >= 0 && i < img.width && j < img.height &&
           img.alpha[size_t(j) * size_t(img.width) + size_t(i)] >= 0.999f;
  };
  for (int j = 0; j < img.height; ++j)
    for (int i = 0; i < img.width; ++i) {
      const size_t p = size_t(j) * size_t(img.width) + size_t(i);
      if (img.alpha[p] < minAlpha) continue;
      if (margin && !(full(i - margin, j) && full(i + margin, j) && full(i, j - margin) &&
                      full(i, j + margin)))
        continue;
      s += (img.rgb[p * 3] + img.rgb[p * 3 + 1] + img.rgb[p * 3 + 2]) / 3.0;
      ++n;
    }
  return n ? s / double(n) : 0;
}
int64_t covered(const RenderImage& img) {
  int64_t n = 0;
  for (float a : img.alpha) n += a >= 0.5f;
  return n;
}

const char* kFlat = R"({
  "btfscene": 1, "name": "flat", "tile": {"size": [1.0, 1.0]},
  "materials": {"white": {"type": "lambert", "albedo": [0.7, 0.7, 0.7]}},
  "parts": [{"name": "ground", "type": "plane", "material": "white"}],
  "simulation": {"texels": [8, 8], "directions": "axis-grid", "grid": [6, 16]}
})";

TEST(Render, FlatTileOnAPlaneIsTheSameInEveryModeAndHasNoSilhouette) {
  const fs::path dir = test::tempDir("render_flat");
  const std::string btfPath = simulate(dir, "flat", kFlat);
  RenderSettings s;
  s.width = s.height = 48;
  s.spp = 2;
  s.camTheta = 50, s.camPhi = -60;
  s.lightTheta = 40, s.lightPhi = 20;
  // The plan drops the visibility map for a flat tile: the plane z = 0 stands in.
  EXPECT_FALSE(BtfSampler(btfPath, "", true, uint64_t(1) << 30).hasVmf());
  const Images im = renderAll(btfPath, "plane", s, true);
  const RenderImage &flat = im.flat, &mapped = im.mapped, &exact = im.exact;
  // Lambert on a plane: E·ρ/π·cos θi at every covered pixel, whatever the mode.
  const double expect = 0.7 / kPi * std::cos(deg2rad(40));
  for (const RenderImage* img : {&flat, &mapped, &exact}) {
    SCOPED_TRACE(img->mode);
    EXPECT_NEAR(meanOver(*img), expect, 2e-3 * expect);
    for (size_t p = 0; p < img->alpha.size(); ++p)
      if (img->alpha[p] == 1.f) {
        ASSERT_NEAR(img->rgb[p * 3], expect, 4e-3 * expect) << p;
      }
  }
  // No silhouettes: the same pixels are covered (edge pixels may differ by a sample).
  EXPECT_GT(covered(flat), 400);
  EXPECT_LE(std::abs(covered(mapped) - covered(flat)), 2);
  EXPECT_LE(std::abs(covered(exact) - covered(flat)), 2);
  const ImageError e = compareImages(mapped, exact);
  EXPECT_LT(e.relRmse, 0.02);
}

TEST(Render, VGroovesAtGrazingAnglesShowTheirAnalyticMasking) {
  // Two V-grooves of depth 1/8 per tile: facets tilted by α = atan(0.5). Seen and lit from
  // θ = 75° across the grooves (past 90° − α), only the facets facing the camera are seen, all of
  // them lit: the image's mean is E·ρ/π·cos(θ − α) and the surface is closed (coverage 1).
  const fs::path dir = test::tempDir("render_vgrooves");
  const std::string btfPath = simulate(dir, "vg", R"({
    "btfscene": 1, "name": "vg", "tile": {"size": [1.0, 1.0]},
    "materials": {"white": {"type": "lambert", "albedo": [0.6, 0.6, 0.6]}},
    "parts": [{"name": "g", "type": "vgrooves", "material": "white", "count": 2, "depth": 0.125}],
    "simulation": {"texels": [16, 16], "directions": "axis-grid", "grid": [6, 16]}
  })",
                                       {{"bounces", "1"}, {"spp", "4"}});
  RenderSettings s;
  s.width = s.height = 128;
  s.spp = 4;
  s.camTheta = s.lightTheta = 75, s.camPhi = s.lightPhi = 0;
  s.bounces = 1;
  ASSERT_TRUE(BtfSampler(btfPath, "", false, uint64_t(1) << 30).hasVmf());
  const Images im = renderAll(btfPath, "plane", s, false);
  const RenderImage &flat = im.flat, &mapped = im.mapped, &exact = im.exact;
  const double alpha = std::atan(0.5);
  const double expect = 0.6 / kPi * std::cos(deg2rad(75) - alpha);
  // Away from the plane's edges (where the exact grooves are cut open).
  EXPECT_NEAR(meanOver(mapped, 0.999f, 3), expect, 0.02 * expect);
  EXPECT_NEAR(meanOver(exact, 0.999f, 3), expect, 0.02 * expect);
  // Coverage: a closed relief covers the plane's footprint, as the flat surface does; the
  // shell's grooves lie under the ridges (z ≤ 0) so nothing shows past the edges.
  const int64_t band = covered(flat);
  EXPECT_GT(band, 1000);
  EXPECT_LE(std::abs(covered(mapped) - band), s.width);  // within one row of pixels
  EXPECT_LE(std::abs(covered(exact) - band), s.width);
}

TEST(Render, TheShellsSilhouetteMatchesTheExactMicroGeometry) {
  // Bumps on the cylinder, seen side on: the exact object's silhouette carries the bumps; the
  // mapped shell shows the same width row by row, within a pixel; the flat base is visibly
  // narrower.
  const fs::path dir = test::tempDir("render_silhouette");
  const std::string btfPath = simulate(dir, "bumps", R"({
    "btfscene": 1, "name": "bumps", "tile": {"size": [1.0, 1.0]},
    "materials": {"white": {"type": "lambert", "albedo": [0.6, 0.6, 0.6]}},
    "parts": [{"name": "b", "type": "bumps", "material": "white", "count": [2, 2],
               "radius": 0.45, "height": 0.2, "resolution": [48, 48]}],
    "simulation": {"texels": [16, 16], "directions": "axis-grid", "grid": [8, 16]}
  })",
                                       {{"bounces", "1"}, {"spp", "2"}});
  RenderSettings s;
  s.width = s.height = 128;
  s.spp = 4;
  s.camTheta = 90, s.camPhi = -90;
  s.tiling = 6;
  const Images im = renderAll(btfPath, "cylinder", s, false);
  const RenderImage &flat = im.flat, &mapped = im.mapped, &exact = im.exact;
  auto width = [&](const RenderImage& img, int row) {
    double w = 0;
    for (int i = 0; i < img.width; ++i) w += img.alpha[size_t(row) * size_t(img.width) + size_t(i)];
    return w;
  };
  double dMapped = 0, dFlat = 0;
  int rows = 0;
  for (int j = 0; j < s.height; ++j) {
    if (width(exact, j) < 4) continue;
    dMapped += std::abs(width(mapped, j) - width(exact, j));
    dFlat += width(exact, j) - width(flat, j);
    ++rows;
  }
  ASSERT_GT(rows, 60);
  dMapped /= rows, dFlat /= rows;
  EXPECT_LE(dMapped, 1.0) << "mean |mapped − exact| width per row, pixels";
  EXPECT_GE(dFlat, 3.0) << "the relief's silhouette the flat mode lacks, pixels per row";
  const ImageError e = compareImages(mapped, exact);
  EXPECT_LE(e.coverageMismatch, 0.02);
}

TEST(Render, ATallReliefShadowsItsNeighboursInMappedAsInExact) {
  // Tall boxes lit at θ = 70°: each shadow falls on the neighbouring texels (and tiles).
  const fs::path dir = test::tempDir("render_shadow");
  const std::string btfPath = simulate(dir, "boxes", R"({
    "btfscene": 1, "name": "boxes", "tile": {"size": [1.0, 1.0]},
    "materials": {"white": {"type": "lambert", "albedo": [0.6, 0.6, 0.6]}},
    "parts": [{"name": "ground", "type": "plane", "material": "white"},
              {"name": "box", "type": "box", "material": "white",
               "center": [0.5, 0.5, 0.25], "size": [0.2, 0.2, 0.5]}],
    "simulation": {"texels": [16, 16], "directions": "axis-grid", "grid": [9, 16]}
  })",
                                       {{"bounces", "1"}, {"spp", "4"}});
  RenderSettings s;
  s.width = s.height = 96;
  s.spp = 4;
  s.camTheta = 0, s.camPhi = 0;
  s.lightTheta = 70, s.lightPhi = 0;
  s.bounces = 1;
  s.tiling = 4;
  s.zoom = 2;  // the middle of the plane: away from its edges, where the exact boxes stop
  const Images im = renderAll(btfPath, "plane", s, false);
  const RenderImage &mapped = im.mapped, &exact = im.exact;
  // Seen from above: the boxes' tops (4 % of the tile) and the ground, lit at E·ρ/π·cos 70°
  // where no box shadows it. A shadow is 0.2 wide and 0.5·tan 70° = 1.37 long: longer than the
  // tile, so it runs on through the neighbouring tiles and darkens the whole strip
  // y ∈ [0.4, 0.6] but for the box's own top — 16 % of the tile. Mean: 0.84 of the lit value.
  const double lit = 0.6 / kPi * std::cos(deg2rad(70));
  EXPECT_NEAR(meanOver(exact) / lit, 0.84, 0.02);
  EXPECT_NEAR(meanOver(mapped) / lit, 0.84, 0.02);
  // And where: the shadowed strip is dark in both (rows of the image run along x).
  const ImageError e = compareImages(mapped, exact);
  EXPECT_LT(e.relRmse, 0.25);
}

TEST(Render, NonHeightFieldTileOnTheCurvedSection) {
  // Spheres floating above a plane (thesis fig. 4.18) on the curved section: the mapped image
  // stays within the tolerance of docs/render.md of the exact one at this small size.
  const fs::path dir = test::tempDir("render_section");
  const std::string btfPath = simulate(dir, "spheres", R"({
    "btfscene": 1, "name": "spheres", "tile": {"size": [1.0, 1.0]},
    "materials": {"ground": {"type": "lambert", "albedo": [0.6, 0.6, 0.6]},
                  "red": {"type": "lambert", "albedo": [0.7, 0.1, 0.1]}},
    "parts": [{"name": "ground", "type": "plane", "material": "ground"},
              {"name": "s", "type": "sphere", "material": "red", "center": [0.5, 0.5, 0.3],
               "radius": 0.15, "segments": 16}],
    "simulation": {"texels": [16, 16], "directions": "axis-grid", "grid": [8, 16]}
  })",
                                       {{"bounces", "1"}, {"spp", "2"}});
  RenderSettings s;
  s.width = s.height = 96;
  s.spp = 4;
  s.lightTheta = 20, s.lightPhi = 0;
  s.bounces = 1;
  const Images im = renderAll(btfPath, "section", s, false);
  const RenderImage &mapped = im.mapped, &exact = im.exact;
  const ImageError e = compareImages(mapped, exact);
  EXPECT_LE(e.coverageMismatch, 0.03);
  EXPECT_NEAR(meanOver(mapped, 0.5f), meanOver(exact, 0.5f), 0.05 * meanOver(exact, 0.5f));
  EXPECT_LE(e.relRmse, 0.30);
}

TEST(Render, UnderAConstantSkyALambertSphereReflectsAlbedoTimesSky) {
  // The furnace: a convex object, no light, a sky of radiance 2 all around. Every point of a
  // Lambertian surface sees the whole sky over its horizon: radiance ρ·2. The exact path tracer
  // gets it sample by sample; flat and mapped sum the BTF over the set's light directions, each
  // weighted by its band's ∫cos dω (they sum to π: exact for a constant aBRDF).
  const fs::path dir = test::tempDir("render_sky");
  const std::string btfPath = simulate(dir, "flat", kFlat);
  RenderSettings s;
  s.width = s.height = 32;
  s.spp = 2;
  s.irradiance = 0;
  s.environment = 2;
  const Images im = renderAll(btfPath, "sphere", s, true);
  const RenderImage &flat = im.flat, &mapped = im.mapped, &exact = im.exact;
  const double expect = 0.7 * 2;
  EXPECT_NEAR(meanOver(exact), expect, 1e-3 * expect);
  EXPECT_NEAR(meanOver(flat), expect, 0.005 * expect);
  EXPECT_NEAR(meanOver(mapped), expect, 0.005 * expect);
}

TEST(Render, BadInputGetsAClearMessage) {
  const fs::path dir = test::tempDir("render_bad");
  const std::string flatBtf = simulate(dir, "flat", kFlat);
  // A relief BTF simulated without its visibility map.
  const std::string noVmf = simulate(dir, "bumps", R"({
    "btfscene": 1, "name": "bumps", "tile": {"size": [1.0, 1.0]},
    "materials": {"white": {"type": "lambert", "albedo": [0.6, 0.6, 0.6]}},
    "parts": [{"name": "b", "type": "bumps", "material": "white", "height": 0.1}],
    "simulation": {"texels": [8, 8], "directions": "axis-grid", "grid": [4, 8]}
  })",
                                     {{"vmf", "off"}});
  auto render = [&](const std::string& in, const std::string& extra,
                    const std::string& out = "o.exr") {
    ops::Request r("render");
    r.set("input", in).set("output", (dir / out).string()).set("size", "16").set("spp", "1");
    r.setFlag("quiet", true);
    std::istringstream ss(extra);
    std::string kv;
    while (ss >> kv) r.set(kv.substr(0, kv.find('=')), kv.substr(kv.find('=') + 1));
    return errorOf([&] { ops::run(r, quiet()); });
  };
  EXPECT_NE(render(noVmf, "mode=mapped").find("has no visibility map"), std::string::npos)
      << render(noVmf, "mode=mapped");
  EXPECT_EQ(render(noVmf, "mode=flat", "ok.exr"), "");  // flat needs no VMF
  // Relief taller than the hills' hollows allow: the shell would fold over itself there (on a
  // convex object it cannot).
  const std::string fold = render(noVmf, "mode=flat relief_scale=60 object=hills");
  EXPECT_NE(fold.find("fold over itself"), std::string::npos) << fold;
  EXPECT_NE(fold.find("radius of curvature"), std::string::npos) << fold;
  EXPECT_NE(render(flatBtf, "object=teapot").find("unknown object 'teapot'"), std::string::npos);
  EXPECT_NE(render(flatBtf, "mode=all", "o.exr").find("side-by-side .png"), std::string::npos);
  EXPECT_NE(render(dir / "flat.json", "mode=mapped").find("renders --mode exact only"),
            std::string::npos);
  EXPECT_NE(render(flatBtf, "camera=30").find("--camera"), std::string::npos);
  // Nothing was written by the refused runs.
  EXPECT_FALSE(fs::exists(dir / "o.exr"));
  // A mesh file without texture coordinates, and one with (resources/meshes/uv_patch.obj).
  std::ofstream(dir / "nouv.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
  const std::string noUv = render(flatBtf, "object=" + (dir / "nouv.obj").string());
  EXPECT_NE(noUv.find("nouv.obj: the mesh has no texture coordinates"), std::string::npos) << noUv;
  EXPECT_EQ(render(flatBtf, "object=" + test::sourceDir() + "/resources/meshes/uv_patch.obj",
                   "patch.exr"),
            "");
  // An object whose texture map is degenerate on a triangle with an area.
  ObjectMesh m = makeObject("plane");
  for (auto& uv : m.uv) uv = {0.5f, 0.5f};
  RenderSettings s;
  const std::string uvErr = errorOf([&] { RenderScene(m, 1, 1, 0, 0, s); });
  EXPECT_NE(uvErr.find("degenerate texture coordinates"), std::string::npos) << uvErr;
}

TEST(Render, CommandWritesImagesAndReportsErrorsAgainstTheExactImage) {
  const fs::path dir = test::tempDir("render_cli");
  const std::string btfPath = simulate(dir, "flat", kFlat);
  ops::Request r("render");
  r.set("input", btfPath).set("output", (dir / "all.png").string()).set("mode", "all");
  r.set("size", "24").set("spp", "1").set("object", "sphere");
  r.setFlag("quiet", true);
  const ops::Report rep = ops::run(r, quiet());
  const auto& res = rep.as<ops::RenderResult>();
  ASSERT_EQ(res.images.size(), 3u);
  EXPECT_EQ(res.images[0].mode, "exact");
  EXPECT_FALSE(res.images[0].errorVsExact);  // exact is the one the others are measured against
  for (const char* f : {"all.png", "all.exact.exr", "all.mapped.exr", "all.flat.exr"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  ASSERT_TRUE(res.images[2].errorVsExact);
  EXPECT_LT(res.images[2].errorVsExact->relRmse, 0.01);
  // The JSON is the typed report serialised.
  EXPECT_EQ(rep.json["images"][2]["error_vs_exact"]["rel_rmse"].get<double>(),
            res.images[2].errorVsExact->relRmse);
  EXPECT_EQ(rep.json["images"].size(), 3u);
  // The exact EXR carries the coverage; a later run measures against it as a reference.
  int w = 0, h = 0;
  std::vector<float> alpha;
  readRgbImage((dir / "all.exact.exr").string(), &w, &h, &alpha);
  EXPECT_EQ(w, 24);
  double cov = 0;
  for (float a : alpha) cov += a;
  EXPECT_GT(cov, 100);
  ops::Request q("render");
  q.set("input", btfPath).set("output", (dir / "flat.exr").string()).set("mode", "flat");
  q.set("size", "24").set("spp", "1").set("object", "sphere");
  q.set("reference", (dir / "all.exact.exr").string());
  q.setFlag("quiet", true);
  const ops::Report rq = ops::run(q, quiet());
  const auto& flat = rq.as<ops::RenderResult>().images.at(0);
  ASSERT_TRUE(flat.error);
  EXPECT_LT(flat.error->relRmse, 0.01);
  EXPECT_EQ(flat.error->mismatchPixels, 0);
  EXPECT_EQ(rq.json["images"][0]["error"]["mismatch_pixels"].get<int64_t>(), 0);
}

}  // namespace
}  // namespace btf
