// The use-case layer: declared requests (ranges, errors naming the option), the per-run thread
// arena, the one outcome of a cancel at every stage (no file, no .partial), and the engine's
// reports.
#include <btf/compress/cbtf.h>
#include <btf/compress/compress.h>
#include <btf/core/progress.h>
#include <btf/core/run_context.h>
#include <btf/ops/ops.h>
#include <btf/sim/simulator.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <thread>

#include "test_util.h"

namespace btf {
namespace {

namespace fs = std::filesystem;

std::string scenePath(const std::string& n) {
  return test::sourceDir() + "/resources/scenes/" + n + ".json";
}

using test::errorOf;

TEST(Request, ValuesAreCheckedAgainstTheDeclaration) {
  ops::Request r("simulate");
  EXPECT_EQ(errorOf([&] { r.set("spp", "0"); }), "--spp: must be in 1..64 (got 0)");
  EXPECT_EQ(errorOf([&] { r.set("spp", "2.5"); }), "--spp: expected an integer, got '2.5'");
  EXPECT_EQ(errorOf([&] { r.set("bias", "nan"); }), "--bias: expected a finite number, got 'nan'");
  EXPECT_EQ(errorOf([&] { r.set("shadows", "soft"); }),
            "--shadows: must be one of map, rays (got 'soft')");
  EXPECT_EQ(errorOf([&] { r.set("frobnicate", "1"); }), "simulate: unknown option 'frobnicate'");
  EXPECT_EQ(errorOf([&] { r.validate(); }), "simulate: SCENE is required");
  EXPECT_EQ(errorOf([] { ops::Request("frobnicate"); }).rfind("unknown command 'frobnicate'", 0),
            0u);
  // Scene-backed keys are absent until given, and go back to the scene when unset.
  EXPECT_FALSE(r.has("spp"));
  r.set("spp", "4");
  EXPECT_TRUE(r.has("spp"));
  EXPECT_EQ(r.i("spp"), 4);
  r.unset("spp");
  EXPECT_FALSE(r.has("spp"));
  // Non-scene keys carry their declared default.
  EXPECT_EQ(r.s("memory_budget"), "4G");
  EXPECT_EQ(r.i("links"), 16);
}

TEST(Request, SceneBlockGivesTheDefaultsAndTheRequestOverrides) {
  const Scene s = loadScene(scenePath("brick"));
  ops::Request r("simulate");
  const SimOptions a = ops::simOptions(s, r);
  const SimOptions scene = optionsFromScene(s);
  EXPECT_EQ(a.spp, scene.spp);
  EXPECT_EQ(a.directions, scene.directions);
  r.set("spp", "3").set("dirs", "4x8").set("texels", "16x8");
  const SimOptions b = ops::simOptions(s, r);
  EXPECT_EQ(b.spp, 3);
  EXPECT_EQ(b.directions, "4x8");
  EXPECT_EQ(b.nu, 16);
  EXPECT_EQ(b.nv, 8);
}

TEST(RunContext, AJobsThreadCountLeavesOtherThreadsUnchanged) {
  const int all = currentThreads();
  ASSERT_GE(all, 1);
  std::atomic<bool> inside{false}, release{false};
  int jobThreads = 0, jobGlobal = 0;
  std::thread job([&] {
    withThreads(1, [&] {
      jobThreads = currentThreads();
      jobGlobal =
          int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
      inside = true;
      while (!release) std::this_thread::yield();
    });
  });
  while (!inside) std::this_thread::yield();
  // The "preview worker": measured while the job holds its one-thread arena.
  int previewThreads = 0;
  std::thread preview([&] { previewThreads = currentThreads(); });
  preview.join();
  const int global =
      int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  release = true;
  job.join();
  EXPECT_EQ(jobThreads, 1);
  EXPECT_EQ(previewThreads, all);
  EXPECT_EQ(global, jobGlobal);  // nothing process-wide was changed
  EXPECT_GE(global, all);
  // Work inside the arena really runs on at most one thread.
  std::atomic<int> concurrent{0}, peak{0};
  withThreads(1, [&] {
    tbb::parallel_for(0, 64, [&](int) {
      const int c = ++concurrent;
      int p = peak.load();
      while (c > p && !peak.compare_exchange_weak(p, c)) {
      }
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      --concurrent;
    });
  });
  EXPECT_EQ(peak.load(), 1);
  EXPECT_THROW(withThreads(-1, [] {}), Error);
}

// Runs `r` and cancels it as the named progress stage starts ("" = before the run), on the
// running thread, so the stage is always reached. Returns the stage the Cancelled outcome
// names; fails the test when the run was not cancelled.
std::string cancelAt(const ops::Request& r, const std::string& stage) {
  CancelToken token;
  ProgressState state;
  bool reached = stage.empty();
  if (stage.empty()) token.cancel();
  state.onStage = [&](const std::string& s) {
    if (!reached && s.rfind(stage, 0) == 0) {
      reached = true;
      token.cancel();
    }
  };
  ProgressState* prev = ProgressReporter::observe(&state);
  RunContext ctx;
  ctx.cancel = &token;
  ctx.progress = false;
  std::string what;
  try {
    ops::run(r, ctx);
    ADD_FAILURE() << r.command() << " at '" << stage << "' was not cancelled";
  } catch (const Cancelled& c) {
    what = c.stage();
  } catch (const std::exception& e) {
    ADD_FAILURE() << r.command() << " at '" << stage << "': not a Cancelled outcome: " << e.what();
  }
  ProgressReporter::observe(prev);
  EXPECT_TRUE(reached) << "stage '" << stage << "' never started";
  return what;
}

TEST(RunContext, CancelAtEveryStageIsOneOutcomeAndLeavesNothing) {
  const auto dir = test::tempDir("ops_cancel");
  const std::string out = (dir / "b.btf").string(), cb = (dir / "b.cbtf").string();
  auto sim = [&](const std::string& o, const std::string& codec) {
    ops::Request r("simulate");
    r.set("scene", scenePath("brick")).set("output", o).set("texels", "16").set("dirs", "8x16");
    if (!codec.empty()) r.set("compress", codec);
    return r;
  };
  // Before anything (estimate, network build, planner), then each progress stage.
  for (const std::string stage : {"", "hit maps", "network light", "aBRDF"}) {
    SCOPED_TRACE("simulate at '" + stage + "'");
    const std::string got = cancelAt(sim(out, ""), stage);
    EXPECT_FALSE(got.empty());
    if (!stage.empty()) {
      EXPECT_EQ(got, stage);  // the stage that was running says so
    }
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(out + ".partial"));
  }
  ops::Request noGi = sim(out, "");
  noGi.set("interreflection", "off");
  EXPECT_FALSE(cancelAt(noGi, "").empty());  // the planner's own probes, no network
  EXPECT_FALSE(fs::exists(out + ".partial"));
  for (const std::string stage : {"training texels", "aBRDF"}) {
    SCOPED_TRACE("streamed at '" + stage + "'");
    EXPECT_FALSE(cancelAt(sim(cb, "svd"), stage).empty());
    EXPECT_FALSE(fs::exists(cb));
    EXPECT_FALSE(fs::exists(cb + ".partial"));
  }
  // A real store for the encoder and the exports.
  ops::Request small = sim(out, "");
  small.set("texels", "8").set("dirs", "4x8").setFlag("quiet", true);
  RunContext quiet;
  quiet.progress = false;
  ops::run(small, quiet);
  ASSERT_TRUE(fs::exists(out));
  ops::Request comp("compress");
  comp.set("input", out).set("output", cb);
  EXPECT_FALSE(cancelAt(comp, "").empty());
  EXPECT_FALSE(fs::exists(cb));
  for (const std::string fmt : {"ubo2003", "ubo2014", "merl"}) {
    SCOPED_TRACE("export " + fmt);
    ops::Request ex("export");
    const std::string target = (dir / ("x." + fmt)).string();
    ex.set("input", out).set("format", fmt).set("output", target);
    EXPECT_FALSE(cancelAt(ex, "").empty());
    EXPECT_FALSE(cancelAt(ex, "export").empty());
    EXPECT_FALSE(fs::exists(target));
  }
}

TEST(Ops, StreamedRunOverTheBudgetIsRefusedWithTheFigures) {
  const auto dir = test::tempDir("ops_budget");
  ops::Request r("simulate");
  r.set("scene", scenePath("brick")).set("output", (dir / "x.cbtf").string());
  r.set("texels", "64").set("dirs", "16x32").set("compress", "nmf").set("memory_budget", "300M");
  r.set("spp", "1");  // uniform 1×1: the simulation alone fits, the encoder on top does not
  RunContext ctx;
  ctx.progress = false;
  const std::string e = errorOf([&] { ops::run(r, ctx); });
  EXPECT_NE(e.find("refusing to start: "), std::string::npos) << e;
  EXPECT_NE(e.find("--memory-budget is 300.0 MiB"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(dir / "x.cbtf"));
}

}  // namespace
}  // namespace btf

namespace btf {
namespace {

// `compare --noise`: the reference's own noise floor from a second seed, and the excess.
TEST(Ops, CompareReportsTheReferencesNoiseFloorAndTheExcess) {
  const auto dir = test::tempDir("ops_noise");
  const std::string a = (dir / "a.btf").string(), a2 = (dir / "a2.btf").string(),
                    b = (dir / "b.cbtf").string();
  RunContext ctx;
  ctx.progress = false;
  for (const auto& [out, seed] : {std::pair{a, "1"}, std::pair{a2, "2"}}) {
    ops::Request s("simulate");
    s.set("scene", scenePath("brick")).set("output", out).set("texels", "8").set("dirs", "4x8");
    s.set("seed", seed).set("spp", "2");
    ops::run(s, ctx);
  }
  ops::Request cr("compress");
  cr.set("input", a).set("output", b).set("codec", "svd").set("components", "2");
  ops::run(cr, ctx);
  ops::Request cmp("compare");
  cmp.set("a", a).set("b", b).set("noise", a2);
  const ops::Report rep = ops::run(cmp, ctx);
  const auto& res = rep.as<ops::CompareResult>();
  const double rel = res.error.relRmse;
  ASSERT_TRUE(res.noise);
  const auto& n = *res.noise;
  const ErrorReport seeds = compareBtfs(*openBtf(a), *openBtf(a2), false);
  EXPECT_GT(seeds.relRmse, 0);  // two seeds differ
  EXPECT_NEAR(n.floorRelRmse, seeds.relRmse / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(n.floorRmse, seeds.rmse / std::sqrt(2.0), 1e-12);
  const double floorRel = n.floorRelRmse;
  const double excess = n.excessRelRmse;
  // The JSON (--json) is the typed report serialised: same figures under the schema's keys.
  EXPECT_EQ(rep.json["relative_rmse"].get<double>(), rel);
  EXPECT_EQ(rep.json["noise"]["excess_relative_rmse"].get<double>(), excess);
  // Asking for another command's report is an error naming the command.
  try {
    (void)rep.as<ops::CompressResult>();
    ADD_FAILURE() << "as<CompressResult>() of a compare report";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'compare'"), std::string::npos) << e.what();
  }
  EXPECT_NEAR(excess * excess + std::min(floorRel, rel) * std::min(floorRel, rel),
              std::max(rel * rel, floorRel * floorRel), 1e-12);
  EXPECT_LE(excess, rel);
}

}  // namespace
}  // namespace btf

namespace btf {
namespace {

// The typed reports: what the studio and the Python package read. Each holds the figures the
// files themselves give, and the JSON is those fields under the schema's keys.
TEST(Ops, TypedReportsHoldTheFilesFiguresAndSerialiseToTheirJson) {
  const auto dir = test::tempDir("ops_typed");
  const std::string raw = (dir / "a.btf").string(), mip = (dir / "a.cbtf").string(),
                    one = (dir / "b.cbtf").string();
  RunContext ctx;
  ctx.progress = false;
  ops::Request s("simulate");
  s.set("scene", scenePath("brick")).set("output", raw).set("texels", "8").set("dirs", "4x8");
  s.set("spp", "1");
  const ops::Report sr = ops::run(s, ctx);
  const auto& sim = sr.as<ops::SimulateResult>();
  ASSERT_TRUE(sim.store);
  EXPECT_FALSE(sim.compressed);
  EXPECT_EQ(sim.nu, 8);
  EXPECT_EQ(sim.directionCount, 32);
  EXPECT_EQ(sim.store->outputBytes, fs::file_size(raw));
  EXPECT_EQ(sim.store->abrdfValues, uint64_t(64) * 32 * 32);
  EXPECT_EQ(sr.json["output_bytes"].get<uint64_t>(), sim.store->outputBytes);

  ops::Request m("compress");
  m.set("input", raw).set("output", mip).set("codec", "svd").setFlag("mip", true);
  const ops::Report mr = ops::run(m, ctx);
  const auto& pyr = mr.as<ops::CompressResult>();
  ASSERT_TRUE(pyr.pyramid);
  ASSERT_EQ(pyr.pyramid->levels.size(), 4u);  // 8², 4², 2², 1²
  EXPECT_EQ(pyr.pyramid->levels[3].nu, 1);
  EXPECT_EQ(pyr.file.compressedBytes, fs::file_size(mip));
  EXPECT_NEAR(pyr.file.ratio, pyr.file.rawBytes / double(pyr.file.compressedBytes), 1e-9);
  EXPECT_EQ(mr.json["levels"].size(), 4u);
  EXPECT_EQ(mr.json["error"]["relative_rmse"].get<double>(), pyr.pyramid->levels[0].relRmse);

  ops::Request c("compress");
  c.set("input", raw).set("output", one).set("codec", "svd").setFlag("compare", true);
  const ops::Report cr = ops::run(c, ctx);
  const auto& cmp = cr.as<ops::CompressResult>();
  EXPECT_FALSE(cmp.pyramid);
  ASSERT_TRUE(cmp.error);
  EXPECT_EQ(cmp.error->values, int64_t(64) * 32 * 32 * 3);
  EXPECT_GE(cmp.error->relRmse, 0);
  EXPECT_LE(cmp.error->relRmse, 1);
  EXPECT_EQ(cr.json["error"]["psnr_db"].get<double>(), cmp.error->psnr);

  ops::Request i("info");
  i.set("btf", mip);
  const ops::Report ir = ops::run(i, ctx);
  const auto& inf = ir.as<ops::InfoResult>();
  EXPECT_TRUE(inf.verified);
  EXPECT_EQ(inf.format, "compressed");
  const auto* z = std::get_if<ops::InfoResult::Compressed>(&inf.details);
  ASSERT_NE(z, nullptr);
  EXPECT_EQ(z->codec, "svd");
  ASSERT_EQ(z->levels.size(), 4u);
  // The file's own record of each level's error is what compress measured.
  for (size_t k = 0; k < 4; ++k) {
    ASSERT_TRUE(z->levels[k].relRmse) << k;
    EXPECT_NEAR(*z->levels[k].relRmse, pyr.pyramid->levels[k].relRmse, 1e-9) << k;
  }
  EXPECT_EQ(ir.json["directions"]["count"].get<int>(), 32);
}

}  // namespace
}  // namespace btf
