// The accuracy-vs-time study: configurations, Pareto front, files written; simulate --method pt
// with direct light only equals the direct simulator with shadow rays.
#include <btf/sim/simulator.h>
#include <btf/sim/study.h>
#include <btf/store/btf_store.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace btf {
namespace {

TEST(Study, ParetoFrontKeepsOnlyUndominatedResults) {
  std::vector<StudyResult> r(4);
  r[0].seconds = 1, r[0].probeRelRmse = 0.10;  // fastest
  r[1].seconds = 2, r[1].probeRelRmse = 0.05;  // better and slower: front
  r[2].seconds = 3, r[2].probeRelRmse = 0.07;  // dominated by r[1]
  r[3].seconds = 4, r[3].probeRelRmse = 0.01;  // most accurate
  markPareto(r);
  EXPECT_TRUE(r[0].pareto);
  EXPECT_TRUE(r[1].pareto);
  EXPECT_FALSE(r[2].pareto);
  EXPECT_TRUE(r[3].pareto);
}

TEST(Study, OneKnobAtATimeAroundTheBase) {
  StudyOptions o;
  o.dirs = {"bonn81", "8x16"};
  o.spp = {1, 2};
  o.bounces = {3, 1};
  o.methods = {"network", "pt"};
  const auto c = studyConfigs(o);
  // base, pt, 8x16, spp2, P1 (the repeated base values are not duplicated)
  ASSERT_EQ(c.size(), 5u);
  EXPECT_EQ(c[0].label(), o.base.label());
  EXPECT_EQ(c[1].method, "pt");
  o.grid = true;
  EXPECT_EQ(studyConfigs(o).size(), 16u);
  // spp 0 is adaptive sampling, named as such.
  StudyConfig a;
  a.spp = 0;
  EXPECT_NE(a.label().find("adaptive"), std::string::npos) << a.label();
  // P = 0 is the planner's own path length (what simulate does by default).
  a.bounces = 0;
  EXPECT_NE(a.label().find(" Pplan "), std::string::npos) << a.label();
}

TEST(Study, CommandWritesTableCsvAndPlot) {
  const auto dir = test::tempDir("study");
  std::string out;
  ASSERT_EQ(test::runBtfsim("study " + test::sourceDir() + "/resources/scenes/brick.json -o " +
                                dir.string() +
                                " --texels 8 --dirs bonn81 --spp 1 --shadows map "
                                "--network-voxels 16 --gather 4 --links 8 --bounces 3,1,0 "
                                "--method network,pt --reference-spp 32 -q",
                            &out),
            0)
      << out;
  const std::string csv = test::readFile(dir / "study.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5);  // header + 4 configurations
  EXPECT_NE(csv.find("Pplan"), std::string::npos);
  EXPECT_NE(csv.find("probe_rel_rmse"), std::string::npos);
  const std::string md = test::readFile(dir / "study.md");
  EXPECT_NE(md.find("| configuration |"), std::string::npos);
  EXPECT_NE(md.find("●"), std::string::npos);  // some result is on the front
  const std::string svg = test::readFile(dir / "study.svg");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  const std::string probes = test::readFile(dir / "probes.csv");
  EXPECT_EQ(std::count(probes.begin(), probes.end(), '\n'), 1 + 4 * 28);
  EXPECT_EQ(csv.find("nan"), std::string::npos);
  EXPECT_EQ(test::runBtfsim("study " + test::sourceDir() + "/resources/scenes/brick.json -o " +
                                dir.string() + " --spp 65",
                            &out),
            1);
  EXPECT_NE(out.find("--spp"), std::string::npos) << out;
}

TEST(Study, PathTracedDirectOnlyBtfEqualsTheDirectSimulator) {
  const Scene s =
      test::sceneFromJson(test::readFile(test::sourceDir() + "/resources/scenes/brick.json"));
  auto run = [&](const std::string& method) {
    SimOptions o;
    o.nu = o.nv = 6;
    o.spp = 2;
    o.directions = "bonn81";
    o.shadows = ShadowMode::Rays;
    o.method = method;
    o.ptPaths = 2;
    o.plan.interreflection = Toggle::Off;
    o.plan.selfShadowing = Toggle::On;
    o.progress = false;
    SimulationJob job(s, o);
    std::vector<float> all;
    job.setChunkSink([&](int, int64_t t0, int64_t t1, const float* v) {
      const size_t n = size_t(job.directions().size());
      all.insert(all.end(), v, v + size_t(t1 - t0) * n * n * 3);
    });
    job.run("", job.estimate(""));
    return all;
  };
  const auto a = run("network"), b = run("pt");
  ASSERT_EQ(a.size(), b.size());
  int bad = 0;
  for (size_t k = 0; k < a.size(); ++k) bad += std::abs(a[k] - b[k]) > 1e-5f * a[k] + 1e-7f;
  EXPECT_EQ(bad, 0);
}

}  // namespace
}  // namespace btf
