// Direct illumination against analytic answers: flat tiles reproduce their BRDF exactly in both
// shadow modes and every direction set; shadow maps agree with shadow rays; reciprocity and
// periodicity of the texel-averaged aBRDF; grazing directions on every resource scene.
#include <btf/core/rng.h>
#include <btf/geometry/tile_builder.h>
#include <btf/sim/brdf_probe.h>
#include <btf/sim/direct.h>
#include <btf/sim/simulator.h>
#include <gtest/gtest.h>

#include <complex>

#include "test_util.h"

namespace btf {
namespace {

std::string flatScene(const std::string& material) {
  return R"({"btfscene": 1, "materials": {"m": )" + material +
         R"(}, "parts": [{"type": "plane", "material": "m", "height": 0.0}]})";
}

/// All values of a small BTF computed in memory: [texel][view][light][rgb].
std::vector<float> simulateAll(const Scene& scene, const std::string& dirs, int texels, int spp,
                               ShadowMode mode, SimulationJob** keep = nullptr) {
  SimOptions o;
  o.nu = o.nv = texels;
  o.directions = dirs;
  o.spp = spp;
  o.shadows = mode;
  static std::unique_ptr<SimulationJob> job;
  job = std::make_unique<SimulationJob>(scene, o);
  if (keep) *keep = job.get();
  HitMaps maps;
  maps.build(job->tracer(), job->directions(), {texels, texels, spp, scene.Lx, scene.Ly, 1});
  DirectIllumination d(job->tracer(), job->materials(), job->directions(), maps, {mode, 1.0f});
  const int n = job->directions().size();
  std::vector<float> out(size_t(texels) * texels * n * n * 3);
  for (int t = 0; t < texels * texels; ++t)
    for (int v = 0; v < n; ++v)
      d.evalTexelView(t % texels, t / texels, v, &out[(size_t(t) * n + v) * n * 3]);
  return out;
}

TEST(Direct, FlatLambertIsAlbedoOverPiEverywhere) {
  const Scene s =
      test::sceneFromJson(flatScene(R"({"type": "lambert", "albedo": [0.9, 0.5, 0.1]})"));
  const float ref[3] = {float(0.9 / kPi), float(0.5 / kPi), float(0.1 / kPi)};
  for (const char* dirs : {"bonn81", "ubo151", "16x32"})
    for (ShadowMode mode : {ShadowMode::Map, ShadowMode::Rays}) {
      SCOPED_TRACE(std::string(dirs) + " " + shadowModeName(mode));
      const auto v = simulateAll(s, dirs, 3, 1, mode);
      int bad = 0;
      for (size_t k = 0; k < v.size(); ++k) bad += std::abs(v[k] - ref[k % 3]) > 1e-5f * ref[k % 3];
      EXPECT_EQ(bad, 0);
    }
}

// Independent double-precision Cook-Torrance (its own formulas: Beckmann Smith via the
// complementary error function, conductor Fresnel via complex indices).
double refCt(const DVec3& wi, const DVec3& wo, bool ggx, double a, int fresnel, double f0,
             double eta, double k, double ks, double kd) {
  const DVec3 h = glm::normalize(wi + wo);
  const double ch = h.z, c2 = ch * ch, t2 = (1 - c2) / c2;
  const double D = ggx ? a * a / (kPi * std::pow(c2 * (a * a - 1) + 1, 2))
                       : std::exp(-t2 / (a * a)) / (kPi * a * a * c2 * c2);
  auto g1 = [&](double c) {
    const double tan = std::sqrt(1 - c * c) / c;
    if (ggx) return 2 / (1 + std::sqrt(1 + a * a * tan * tan));
    const double m = 1 / (a * tan);
    const double lambda = (-0.5 * std::erfc(m)) + std::exp(-m * m) / (2 * m * std::sqrt(kPi));
    return 1 / (1 + lambda);
  };
  const double cd = glm::dot(wi, h);
  double F = 1;
  if (fresnel == 1) F = f0 + (1 - f0) * std::pow(1 - cd, 5);
  if (fresnel == 2) {
    const std::complex<double> n(eta, k);
    const std::complex<double> ct = std::sqrt(1.0 - (1 - cd * cd) / (n * n));
    F = 0.5 * (std::norm((cd - n * ct) / (cd + n * ct)) + std::norm((n * cd - ct) / (n * cd + ct)));
  }
  return kd / kPi + ks * D * g1(wi.z) * g1(wo.z) * F / (4 * wi.z * wo.z);
}

TEST(Direct, FlatCookTorranceEqualsTheAnalyticBrdf) {
  const DirectionSet dirs = DirectionSet::fromName("bonn81");
  for (const char* dist : {"ggx", "beckmann"})
    for (int fr = 0; fr < 3; ++fr) {
      const char* fname[] = {"none", "schlick", "conductor"};
      const std::string mat =
          std::string(
              R"({"type": "cook_torrance", "diffuse": 0.2, "specular": 0.7, "roughness": 0.35, "distribution": ")") +
          dist + R"(", "fresnel": ")" + fname[fr] + R"(", "f0": 0.3, "eta": 0.5, "k": 2.5})";
      SCOPED_TRACE(std::string(dist) + " " + fname[fr]);
      const Scene s = test::sceneFromJson(flatScene(mat));
      const auto v = simulateAll(s, "bonn81", 2, 1, ShadowMode::Map);
      const int n = dirs.size();
      double worst = 0;
      for (int vi = 0; vi < n; ++vi)
        for (int li = 0; li < n; ++li) {
          const double ref =
              refCt(dirs[li].w, dirs[vi].w, dist[0] == 'g', 0.35, fr, 0.3, 0.5, 2.5, 0.7, 0.2);
          const double got = v[(size_t(vi) * n + li) * 3];
          worst = std::max(worst, std::abs(got - ref) / ref);
        }
      EXPECT_LT(worst, 2e-4);
    }
}

TEST(Direct, ShadowMapAgreesWithShadowRays) {
  // Brick: measure the disagreement of the two visibility modes, per value and tile-averaged.
  const Scene s = loadScene(test::sourceDir() + "/resources/scenes/brick.json");
  const int T = 24;
  const auto a = simulateAll(s, "bonn81", T, 2, ShadowMode::Map);
  const auto b = simulateAll(s, "bonn81", T, 2, ShadowMode::Rays);
  const int n = 81;
  double sumA = 0, sumDiff = 0;
  size_t differ = 0, count = 0;
  double worstAvg = 0;
  for (int p = 0; p < n * n; ++p) {
    double avgA = 0, avgB = 0;
    for (int t = 0; t < T * T; ++t) {
      const size_t k = (size_t(t) * n * n + p) * 3;
      avgA += a[k];
      avgB += b[k];
      sumA += a[k];
      sumDiff += std::abs(a[k] - b[k]);
      differ += std::abs(a[k] - b[k]) > 0.1 * std::max(a[k], b[k]);
      ++count;
    }
    if (avgB > 1e-3) worstAvg = std::max(worstAvg, std::abs(avgA - avgB) / avgB);
  }
  const double relL1 = sumDiff / sumA, frac = double(differ) / double(count);
  std::printf(
      "[ measured ] shadow map vs rays on brick %dx%d spp 2 bonn81: relative L1 %.4f, values "
      "differing "
      "by >10%%: %.2f%%, worst tile-averaged pair %.4f\n",
      T, T, relL1, 100 * frac, worstAvg);
  EXPECT_LT(relL1, 0.03);
  EXPECT_LT(frac, 0.05);
  EXPECT_LT(worstAvg, 0.05);
}

TEST(Direct, ReciprocityOfTheAveragedBrdfOnHeightFields) {
  const char* scenes[] = {
      R"([{"type": "sine", "material": "m", "amplitude": 0.1, "periods": [2, 1]}])",
      R"([{"type": "vgrooves", "material": "m", "count": 3, "depth": 0.25}])",
      R"([{"type": "bumps", "material": "m", "count": [3, 3], "height": 0.12, "radius": 0.4, "shape": "gaussian"}])"};
  const std::vector<std::array<double, 4>> pairs = {
      {30, 0, 60, 90}, {45, 20, 20, 200}, {60, 45, 35, 180}, {70, 10, 40, 300}};
  for (const char* parts : scenes) {
    SCOPED_TRACE(parts);
    const Scene s = test::sceneFromJson(
        std::string(R"({"btfscene": 1, "materials": {"m": {"type": "cook_torrance",
      "diffuse": 0.5, "specular": 0.5, "roughness": 0.4, "fresnel": "none"}}, "parts": )") +
        parts + "}");
    const TileGeometry g = buildTileGeometry(s);
    const PeriodicTracer tr(g);
    const auto mats = compileMaterials(s);
    std::vector<DirectionPair> fw, bw;
    for (const auto& p : pairs) {
      fw.push_back(pairFromDegrees(p[0], p[1], p[2], p[3]));
      bw.push_back(pairFromDegrees(p[2], p[3], p[0], p[1]));
    }
    const auto a = averagedBrdf(tr, mats, fw, 160), b = averagedBrdf(tr, mats, bw, 160);
    for (size_t k = 0; k < pairs.size(); ++k) {
      const double rel = std::abs(a[k].x - b[k].x) / std::max({a[k].x, b[k].x, 1e-3f});
      std::printf("[ measured ] reciprocity pair %zu: %.5f vs %.5f (rel %.4f)\n", k, a[k].x, b[k].x,
                  rel);
      EXPECT_LT(rel, 0.02);
    }
  }
}

TEST(Direct, PeriodicityTileEqualsTwoByTwoRepeat) {
  const Scene one = test::sceneFromJson(R"({"btfscene": 1, "tile": {"size": [1, 1]},
    "materials": {"m": {"type": "lambert", "albedo": 0.7}},
    "parts": [{"type": "sine", "material": "m", "amplitude": 0.1, "periods": [1, 1], "resolution": [48, 48]}]})");
  const Scene four = test::sceneFromJson(R"({"btfscene": 1, "tile": {"size": [2, 2]},
    "materials": {"m": {"type": "lambert", "albedo": 0.7}},
    "parts": [{"type": "sine", "material": "m", "amplitude": 0.1, "periods": [2, 2], "resolution": [96, 96]}]})");
  const TileGeometry g1 = buildTileGeometry(one), g4 = buildTileGeometry(four);
  const PeriodicTracer t1(g1), t4(g4);
  const auto m = compileMaterials(one);
  std::vector<DirectionPair> pairs;
  for (auto p : std::vector<std::array<double, 4>>{
           {10, 0, 20, 90}, {60, 30, 50, 200}, {75, 0, 80, 180}, {85, 45, 30, 45}})
    pairs.push_back(pairFromDegrees(p[0], p[1], p[2], p[3]));
  const auto a = averagedBrdf(t1, m, pairs, 128), b = averagedBrdf(t4, m, pairs, 256);
  for (size_t k = 0; k < pairs.size(); ++k) EXPECT_NEAR(a[k].x, b[k].x, 0.01 * a[k].x) << k;
}

TEST(Direct, GrazingDirectionsOnEveryResourceSceneStayFiniteAndNonNegative) {
  const auto dir = std::filesystem::path(test::sourceDir()) / "resources" / "scenes";
  // Views and lights at 89.9° (and a few ordinary ones), both shadow modes.
  for (const auto& f : std::filesystem::directory_iterator(dir)) {
    if (f.path().extension() != ".json") continue;
    SCOPED_TRACE(f.path().filename().string());
    const Scene s = loadScene(f.path());
    SimOptions o;
    o.nu = o.nv = 6;
    SimulationJob job(s, o);
    const DirectionSet dirs = DirectionSet::fromRings("grazing", {{30, 3, 0}, {89.9, 8, 0}});
    for (ShadowMode mode : {ShadowMode::Map, ShadowMode::Rays}) {
      HitMaps maps;
      maps.build(job.tracer(), dirs, {6, 6, 2, s.Lx, s.Ly, 1});
      DirectIllumination d(job.tracer(), job.materials(), dirs, maps, {mode, 1.0f});
      std::vector<float> out(size_t(dirs.size()) * 3);
      double total = 0;
      for (int t = 0; t < 36; ++t)
        for (int v = 0; v < dirs.size(); ++v) {
          d.evalTexelView(t % 6, t / 6, v, out.data());
          for (float x : out) {
            ASSERT_TRUE(std::isfinite(x));
            ASSERT_GE(x, 0.0f);
            total += x;
          }
        }
      EXPECT_GT(total, 0);
    }
  }
}

}  // namespace
}  // namespace btf
