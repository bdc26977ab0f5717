// Exact visibility inside the simulator (SimulationJob with --visibility exact, or auto on a
// faceted scene): against uniform high-spp sampling on every resource scene, reciprocity of the
// tile average at default settings, thread-count independence, the studio's one-pair preview,
// the plan's decision, clear errors and a killed run that resumes to the same bytes.
#include <btf/core/parallel.h>
#include <btf/scene/scene.h>
#include <btf/sim/simulator.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "sim_test_util.h"

namespace btf {
namespace {

using test::relativeRmse;
using test::resourceScene;
using test::runAll;
using test::sceneOptions;

TEST(ExactSim, FacetedScenesGoExactByDefaultAndThePlanSaysSo) {
  const Scene brick = resourceScene("brick");
  SimOptions o = sceneOptions(brick, 8, "4x8");
  ASSERT_TRUE(o.adaptive);
  SimulationJob job(brick, o);
  EXPECT_FALSE(job.adaptive());
  ASSERT_NE(job.exactDirect(), nullptr);
  EXPECT_EQ(job.visibilityName(), "exact");
  bool found = false;
  for (const auto& d : job.plan().decisions)
    if (d.effect == "visibility") {
      found = true;
      EXPECT_EQ(d.value, "exact");
      EXPECT_FALSE(d.forced);
      EXPECT_NE(d.reason.find("faces flat"), std::string::npos) << d.reason;
    }
  EXPECT_TRUE(found);
  // Curved parts keep the adaptive sampler unless exact is asked for.
  const Scene weave = resourceScene("weave");
  SimOptions w = sceneOptions(weave, 8, "4x8");
  EXPECT_EQ(SimulationJob(weave, w).visibilityName(), "sampled");
  w.visibility = "exact";
  EXPECT_EQ(SimulationJob(weave, w).visibilityName(), "exact+sampled");
  // --visibility sampled keeps the sampler on a faceted scene; uniform sampling is the reference.
  o.visibility = "sampled";
  EXPECT_TRUE(SimulationJob(brick, o).adaptive());
  o.visibility = "auto";
  o.adaptive = false;
  EXPECT_EQ(SimulationJob(brick, o).visibilityName(), "sampled");
}

TEST(ExactSim, BadVisibilityIsAClearError) {
  const Scene s = resourceScene("brick");
  SimOptions o = sceneOptions(s, 8, "4x8");
  o.visibility = "area";
  try {
    SimulationJob job(s, o);
    FAIL() << "accepted --visibility area";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'area'"), std::string::npos) << e.what();
  }
  o.visibility = "exact";
  o.method = "pt";
  EXPECT_THROW(SimulationJob(s, o), Error);
}

TEST(ExactSim, DirectLightEqualsUniformHighSppOnEveryResourceScene) {
  // 6 × 6 texels, 4 × 8 directions, direct light only, against uniform 32 × 32. Every face
  // flat (brick, V-grooves): exact has no sampling error, so its distance to 32 × 32 is that
  // reference's own error — the edges' K^-3/2 law puts it at 16 × 16's distance / 2^1.5.
  // Curved parts: the flat faces exact, the smooth ones sampled uniformly on the hit maps; with
  // 16 × 16 maps the mix is as near 32 × 32 as uniform 16 × 16 is (nothing counted twice or
  // left out), with the default 4 × 4 maps it is printed (what decoupled shading would buy).
  // (Of the curved scenes, one of each kind: bumps and spheres on a flat floor, weave's tubes,
  // random's height field; the others measured alike, in docs/accuracy.md.)
  for (const char* name : {"brick", "vgrooves", "bumps", "spheres", "weave", "random"}) {
    SCOPED_TRACE(name);
    const Scene s = resourceScene(name);
    SimOptions o = sceneOptions(s, 6, "4x8");
    o.plan.interreflection = Toggle::Off;
    o.visibility = "exact";
    SimReport rep;
    const auto ex = runAll(s, o, &rep);
    EXPECT_NE(rep.visibility, "sampled");
    for (float v : ex) ASSERT_TRUE(std::isfinite(v) && v >= 0);
    SimOptions u = o;
    u.visibility = "sampled";
    u.adaptive = false;
    u.spp = 32;
    const auto u32 = runAll(s, u);
    u.spp = 16;
    const auto u16 = runAll(s, u);
    const double e = relativeRmse(u32, ex), u16e = relativeRmse(u32, u16);
    if (rep.visibility == "exact") {
      std::printf("  %-9s exact vs 32x32 %.3f %%; 16x16 vs 32x32 %.3f %%\n", name, 100 * e,
                  100 * u16e);
      EXPECT_LT(e, 0.5 * u16e + 1e-4);
      continue;
    }
    o.adaptive = false;
    o.spp = 16;
    const double e16 = relativeRmse(u32, runAll(s, o));
    std::printf("  %-9s exact+sampled vs 32x32: 4x4 maps %.3f %%, 16x16 maps %.3f %%; 16x16 vs "
                "32x32 %.3f %%\n",
                name, 100 * e, 100 * e16, 100 * u16e);
    EXPECT_LT(e16, 1.25 * u16e + 1e-3);
  }
}

TEST(ExactSim, TileAverageIsReciprocalAtDefaultSettings) {
  // Brick and V-grooves go exact by default: their direct light is reciprocal up to float
  // rounding, and so is the reciprocal gather's indirect light — at every pair, grazing
  // included (the one-sided gather left 0.55 % and 1.04 % at θ ≤ 60°). Spheres are sampled:
  // what is left is the adaptive sampler's own error.
  for (const char* name : {"brick", "vgrooves", "spheres"}) {
    SCOPED_TRACE(name);
    const Scene s = resourceScene(name);
    const SimOptions o = sceneOptions(s, 16, "4x8");
    SimReport rep;
    const auto all = runAll(s, o, &rep);
    const DirectionSet d = DirectionSet::fromName("4x8");
    const int n = d.size();
    std::vector<double> avg(size_t(n) * n, 0.0);
    for (size_t t = 0; t < 256; ++t)
      for (size_t k = 0; k < avg.size(); ++k) avg[k] += all[(t * avg.size() + k) * 3];
    double worst = 0;
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) {
        const bool exact = rep.visibility == "exact";
        if (!exact && (d[a].theta > deg2rad(60) || d[b].theta > deg2rad(60))) continue;
        const double x = avg[size_t(a) * n + b], y = avg[size_t(b) * n + a];
        if (std::max(x, y) < 1e-3 * 256) continue;
        worst = std::max(worst, std::abs(x - y) / std::max(x, y));
      }
    std::printf("  %-9s %-8s worst reciprocity gap of the tile average %.4f %%\n", name,
                rep.visibility.c_str(), 100 * worst);
    EXPECT_LT(worst, rep.visibility == "exact" ? 1e-4 : 0.01);
  }
}

TEST(ExactSim, DirectLightAloneIsReciprocalPerTexelAverage) {
  // Without inter-reflection every value of a faceted tile is exact, so the tile average of
  // (view, light) and (light, view) agree to float rounding at every pair, grazing included.
  const Scene s = resourceScene("vgrooves");
  SimOptions o = sceneOptions(s, 8, "4x8");
  o.plan.interreflection = Toggle::Off;
  const auto all = runAll(s, o);
  const int n = 32;
  std::vector<double> avg(size_t(n) * n, 0.0);
  for (size_t t = 0; t < 64; ++t)
    for (size_t k = 0; k < avg.size(); ++k) avg[k] += all[(t * avg.size() + k) * 3];
  double worst = 0;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      const double x = avg[size_t(a) * n + b], y = avg[size_t(b) * n + a];
      if (std::max(x, y) < 1e-4) continue;
      worst = std::max(worst, std::abs(x - y) / std::max(x, y));
    }
  EXPECT_LT(worst, 1e-4);
}

TEST(ExactSim, SameValuesWithAnyThreadCountAndInAPreview) {
  const Scene s = resourceScene("brick");
  const SimOptions o = sceneOptions(s, 8, "4x8");
  std::vector<float> one, two;
  withThreads(1, [&] { one = runAll(s, o); });
  withThreads(2, [&] { two = runAll(s, o); });
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(0, std::memcmp(one.data(), two.data(), one.size() * sizeof(float)));
  // The studio's one-pair preview: the same exact direct light and the same gather.
  SimulationJob job(s, o);
  const DirectionSet& d = job.directions();
  const int n = d.size(), view = 9, light = 22;
  const auto img = job.renderPair(d[view], d[light], 8, 8, true);
  double worst = 0;
  for (int t = 0; t < 64; ++t)
    for (int c = 0; c < 3; ++c) {
      const float a = one[((size_t(t) * n + view) * n + light) * 3 + c], b = img[size_t(t) * 3 + c];
      worst = std::max(worst, double(std::abs(a - b)) / std::max(1.0f, std::abs(a)));
    }
  EXPECT_LT(worst, 1e-5);
}

TEST(ExactSim, KilledRunResumesToTheSameBytes) {
  const auto dir = test::tempDir("exact_resume");
  const std::string scene = test::sourceDir() + "/resources/scenes/vgrooves.json";
  const std::string common = " --texels 8 --dirs 4x8 --visibility exact --chunk-texels 8 -q";
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + scene + " -o " + (dir / "full.btf").string() + common +
                                " --json",
                            &out),
            0)
      << out;
  EXPECT_NE(out.find("\"visibility\": \"exact\""), std::string::npos) << out;
  {
    // The hidden-surface removal's own time is reported, as a part of the wall time.
    const auto j = nlohmann::json::parse(out.substr(out.find('{')));
    const double ex = j.at("exact_visibility_seconds").get<double>();
    EXPECT_GE(ex, 0) << out;
    EXPECT_LE(ex, j.at("wall_seconds").get<double>()) << out;
  }
  const std::string part = (dir / "cut.btf").string();
  EXPECT_EQ(test::runBtfsim("simulate " + scene + " -o " + part + common, &out,
                            "BTF_TEST_ABORT_AFTER_CHUNKS=2"),
            75)
      << out;
  ASSERT_TRUE(std::filesystem::exists(part + ".partial"));
  ASSERT_EQ(
      test::runBtfsim("simulate " + scene + " -o " + part + common + " --resume --json", &out), 0)
      << out;
  EXPECT_NE(out.find("\"chunks_resumed\": 2"), std::string::npos) << out;
  EXPECT_EQ(test::readFile(part), test::readFile(dir / "full.btf"));
}

}  // namespace
}  // namespace btf
