// The live previews compute what the simulator stores: the preview image of a (view, light)
// pair of the set equals `btfsim slice` of the simulated BTF, and the BRDF slice equals
// `btfsim brdf --method direct` at the same directions; a flat Lambert tile previews as ρ/π.
#include <btf/io/image_io.h>
#include <gtest/gtest.h>
#include <ui/preview.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include "test_util.h"

using namespace btf;
using namespace btf::ui;
using namespace btf::test;

namespace {

PreviewResult runPreview(const PreviewRequest& r) {
  PreviewWorker w;
  const uint64_t gen = w.request(r);
  PreviewResult res;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(300);
  while (std::chrono::steady_clock::now() < end) {
    PreviewResult x;
    if (w.poll(&x) && x.generation == gen) {
      res = x;
      if (res.done || !res.error.empty()) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return res;
}

std::string brickWithGrid(const std::filesystem::path& dir) {
  std::string s = readFile(sourceDir() + "/resources/scenes/brick.json");
  const std::string axes = "\"axis-grid\", \"grid\": [6, 16]";
  const auto k = s.find(axes);
  s.replace(k, axes.size(), "\"grid\", \"grid\": [4, 8]");
  std::ofstream(dir / "brick.json") << s;
  return s;
}

}  // namespace

TEST(Preview, ImageEqualsBtfsimSliceOfTheSimulatedBtf) {
  const auto dir = tempDir("ui_preview_slice");
  const std::string scene = brickWithGrid(dir);
  std::string out;
  ASSERT_EQ(runBtfsim("simulate " + (dir / "brick.json").string() +
                          " --texels 16 --dirs 4x8 -q -o " + (dir / "b.btf").string(),
                      &out),
            0)
      << out;
  // Grid 4x8 cell centres: θ = 11.25, 33.75, 56.25, 78.75; φ = 22.5 + 45 j.
  const std::string view = "33.75,67.5", light = "56.25,22.5";
  ASSERT_EQ(runBtfsim("slice " + (dir / "b.btf").string() + " --view " + view + " --light " +
                          light + " -o " + (dir / "slice.exr").string(),
                      &out),
            0)
      << out;
  int w = 0, h = 0;
  const auto slice = readRgbImage((dir / "slice.exr").string(), &w, &h);
  ASSERT_EQ(w, 16);
  PreviewRequest r;
  r.sceneJson = scene;
  r.source = "brick.json";
  r.baseDir = dir;
  r.size = 16;
  r.thetaV = 33.75, r.phiV = 67.5, r.thetaL = 56.25, r.phiL = 22.5;
  r.matrix = false;
  const PreviewResult res = runPreview(r);
  ASSERT_TRUE(res.error.empty()) << res.error;
  ASSERT_TRUE(res.imageFinal);
  ASSERT_EQ(res.nu, 16);
  EXPECT_NE(res.plan.find("interreflection"), std::string::npos) << res.plan;
  double peak = 0, maxDiff = 0;
  for (int v = 0; v < 16; ++v)
    for (int u = 0; u < 16; ++u)
      for (int c = 0; c < 3; ++c) {
        // The EXR's top row is texel row v = Nv − 1.
        const float a = slice[(size_t(15 - v) * 16 + size_t(u)) * 3 + size_t(c)];
        const float b = res.image[(size_t(v) * 16 + size_t(u)) * 3 + size_t(c)];
        peak = std::max(peak, double(a));
        maxDiff = std::max(maxDiff, double(std::abs(a - b)));
      }
  ASSERT_GT(peak, 0.01);
  EXPECT_LE(maxDiff, 1e-5 * peak) << "preview differs from the stored slice";
}

TEST(Preview, BrdfSliceEqualsBtfsimBrdfDirect) {
  const auto dir = tempDir("ui_preview_brdf");
  const std::string scene = brickWithGrid(dir);
  PreviewRequest r;
  r.sceneJson = scene;
  r.source = "brick.json";
  r.baseDir = dir;
  r.size = 16;
  r.thetaL = 40, r.phiL = 30;
  r.brdfGrid = 9;
  r.brdfSamples = 8;
  r.matrix = false;
  const PreviewResult res = runPreview(r);
  ASSERT_TRUE(res.error.empty()) << res.error;
  ASSERT_GT(res.brdfPairs.size(), 40u);
  {
    std::ofstream f(dir / "pairs.csv");
    f << "theta_i,phi_i,theta_o,phi_o\n";
    f.precision(17);
    for (const auto& p : res.brdfPairs)
      f << p[0] << "," << p[1] << "," << p[2] << "," << p[3] << "\n";
  }
  std::string out;
  ASSERT_EQ(runBtfsim("brdf " + (dir / "brick.json").string() +
                          " --method direct --spp 8 --pairs " + (dir / "pairs.csv").string(),
                      &out),
            0)
      << out;
  std::istringstream in(out);
  std::string line;
  std::getline(in, line);  // header
  size_t k = 0;
  double peak = 0;
  while (std::getline(in, line)) {
    double v[7];
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3],
                          &v[4], &v[5], &v[6]),
              7)
        << line;
    ASSERT_LT(k, res.brdfValues.size());
    const Rgb& p = res.brdfValues[k];
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(v[4 + c], p[c], 1e-6 * std::max(1.0, std::abs(v[4 + c]))) << "pair " << k;
      peak = std::max(peak, v[4 + c]);
    }
    ++k;
  }
  EXPECT_EQ(k, res.brdfValues.size());
  EXPECT_GT(peak, 0.05);
  // The curves are finite and non-negative, in-plane at θo = 0 equals cross-plane there.
  ASSERT_EQ(res.inPlane.size(), res.curveTheta.size());
  for (size_t i = 0; i < res.inPlane.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      EXPECT_TRUE(std::isfinite(res.inPlane[i][c]) && res.inPlane[i][c] >= 0);
      EXPECT_TRUE(std::isfinite(res.crossPlane[i][c]) && res.crossPlane[i][c] >= 0);
    }
}

TEST(Preview, FlatLambertTileIsAlbedoOverPiEverywhereAndTheMatrixToo) {
  PreviewRequest r;
  r.sceneJson = R"({"btfscene": 1, "name": "flat", "tile": {"size": [1, 1]},
    "materials": {"white": {"type": "lambert", "albedo": [0.8, 0.5, 0.25]}},
    "parts": [{"name": "ground", "type": "plane", "material": "white"}],
    "simulation": {"directions": "grid", "grid": [4, 8]}})";
  r.size = 8;
  r.thetaV = 70, r.phiV = 200, r.thetaL = 85, r.phiL = 10;  // grazing light
  const PreviewResult res = runPreview(r);
  ASSERT_TRUE(res.error.empty()) << res.error;
  const float want[3] = {0.8f / float(kPi), 0.5f / float(kPi), 0.25f / float(kPi)};
  for (size_t i = 0; i < res.image.size(); ++i) EXPECT_NEAR(res.image[i], want[i % 3], 1e-5);
  ASSERT_EQ(res.matrix.size(), 32u * 32u * 3u);
  for (size_t i = 0; i < res.matrix.size(); ++i) EXPECT_NEAR(res.matrix[i], want[i % 3], 1e-5);
  for (const Rgb& v : res.brdfValues) EXPECT_NEAR(v.x, want[0], 1e-5);
}

TEST(Preview, SceneErrorsAreReportedNotThrown) {
  PreviewRequest r;
  r.sceneJson = R"({"btfscene": 1, "materials": {}, "parts": []})";
  const PreviewResult res = runPreview(r);
  EXPECT_NE(res.error.find("parts"), std::string::npos) << res.error;
  EXPECT_TRUE(res.image.empty());
}
