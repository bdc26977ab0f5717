// The studio's jobs are the engine's requests: the same simulate → compress stream as btfsim
// writes the same bytes, the memory budget refuses a studio Stream job with the CLI's message,
// and the scene's simulation block (not a copy in the form) sets a job's spp.
#include <btf/ops/ops.h>
#include <btf/sim/simulator.h>
#include <gtest/gtest.h>
#include <ui/job_requests.h>
#include <ui/panels/panels.h>

#include <filesystem>

#include "test_util.h"

using namespace btf;
using namespace btf::ui;
namespace fs = std::filesystem;

namespace {

std::string scenePath(const std::string& n) {
  return test::sourceDir() + "/resources/scenes/" + n + ".json";
}

// Runs one studio job to its end on a queue (as the Jobs panel does).
std::shared_ptr<Job> runJob(std::unique_ptr<Job> job) {
  JobQueue q;
  const int id = q.submit(std::move(job));
  EXPECT_TRUE(q.waitAll(300));
  return q.find(id);
}

}  // namespace

TEST(JobRequests, StudioStreamWritesTheBytesOfBtfsimSimulateCompress) {
  const auto dir = test::tempDir("ui_stream_same");
  const std::string cli = (dir / "cli.cbtf").string(), studio = (dir / "studio.cbtf").string();
  const std::string scene = scenePath("brick");
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + scene + " -o " + cli +
                                " --texels 8 --dirs 4x8 --spp 2 --compress nmf --target-ratio 40 "
                                "--threads 1 -q",
                            &out),
            0)
      << out;
  JobForm f;
  f.threads = 1;
  f.targetRatio = 40;
  f.sim.set("texels", "8").set("dirs", "4x8").set("spp", "2");
  const auto sc = std::make_shared<const Scene>(loadScene(scene));
  const auto job = runJob(opJob(simulateRequest(f, scene, studio, "nmf"), sc));
  ASSERT_EQ(job->status.load(), JobStatus::Done) << job->message;
  const std::string a = test::readFile(cli), b = test::readFile(studio);
  ASSERT_FALSE(a.empty());
  EXPECT_TRUE(a == b) << "the studio's stream differs from btfsim simulate --compress";
  // The same for the raw store and a compress job against btfsim compress.
  const std::string rawCli = (dir / "cli.btf").string(), rawStudio = (dir / "studio.btf").string();
  ASSERT_EQ(test::runBtfsim("simulate " + scene + " -o " + rawCli +
                                " --texels 8 --dirs 4x8 --spp 2 --threads 1 -q",
                            &out),
            0)
      << out;
  ASSERT_EQ(runJob(opJob(simulateRequest(f, scene, rawStudio, ""), sc))->status.load(),
            JobStatus::Done);
  EXPECT_TRUE(test::readFile(rawCli) == test::readFile(rawStudio));
  const std::string cCli = (dir / "c_cli.cbtf").string(),
                    cStudio = (dir / "c_studio.cbtf").string();
  ASSERT_EQ(test::runBtfsim("compress " + rawCli + " -o " + cCli +
                                " --codec svd --target-ratio 40 --threads 1 -q",
                            &out),
            0)
      << out;
  ASSERT_EQ(
      runJob(opJob(compressRequest(f, rawCli, cStudio, "svd", false), nullptr))->status.load(),
      JobStatus::Done);
  EXPECT_TRUE(test::readFile(cCli) == test::readFile(cStudio));
}

TEST(JobRequests, StudioStreamOverTheBudgetIsRefusedWithTheCliMessage) {
  const auto dir = test::tempDir("ui_stream_budget");
  const std::string scene = scenePath("brick");
  std::string out;
  const std::string cliOut = (dir / "cli.cbtf").string();
  EXPECT_EQ(test::runBtfsim("simulate " + scene + " -o " + cliOut +
                                " --texels 64 --dirs 16x32 --compress nmf --memory-budget 300M -q",
                            &out),
            1);
  const std::string prefix = "btfsim: error: ";
  ASSERT_EQ(out.rfind(prefix, 0), 0u) << out;
  std::string cliMessage = out.substr(prefix.size());
  while (!cliMessage.empty() && cliMessage.back() == '\n') cliMessage.pop_back();
  EXPECT_NE(cliMessage.find("refusing to start"), std::string::npos) << cliMessage;

  JobForm f;
  f.sim.set("texels", "64").set("dirs", "16x32").set("memory_budget", "300M");
  f.targetRatio = 0;
  const std::string studioOut = (dir / "studio.cbtf").string();
  auto req = simulateRequest(f, scene, studioOut, "nmf");
  const auto job = runJob(opJob(req, std::make_shared<const Scene>(loadScene(scene))));
  EXPECT_EQ(job->status.load(), JobStatus::Failed);
  EXPECT_EQ(job->message, cliMessage);
  EXPECT_FALSE(fs::exists(studioOut));
  EXPECT_FALSE(fs::exists(studioOut + ".partial"));
}

TEST(JobRequests, TheScenesSimulationBlockSetsTheJobUnlessTheFormOverridesIt) {
  const std::string scene = scenePath("brick");
  Scene s = loadScene(scene);
  JobForm f;
  const auto req = simulateRequest(f, scene, "out/x.btf", "");
  EXPECT_FALSE(req.has("spp"));
  EXPECT_EQ(ops::simOptions(s, req).spp, optionsFromScene(s).spp);
  // The scene panel changes spp: the next job follows.
  s.simulation.set("spp", ParamValue{{5}, ""});
  EXPECT_EQ(ops::simOptions(s, req).spp, 5);
  // A value typed in the form overrides it, validated by the engine's declaration.
  f.sim.set("spp", "3");
  EXPECT_EQ(ops::simOptions(s, simulateRequest(f, scene, "out/x.btf", "")).spp, 3);
  EXPECT_THROW(f.sim.set("spp", "0"), Error);
  EXPECT_THROW(f.sim.set("spp", "65"), Error);
}

TEST(JobRequests, CodecOptionsOfTheFormReachCompressAndStreamRequests) {
  JobForm f;
  f.codecOptions.set("beta", "0.9").set("max_rank", "4").set("memory_budget", "1G");
  const auto c = compressRequest(f, "in.btf", "out.cbtf", "nmf", false);
  EXPECT_DOUBLE_EQ(c.f("beta"), 0.9);
  EXPECT_EQ(c.i("max_rank"), 4);
  EXPECT_EQ(c.s("memory_budget"), "1G");
  const auto s = simulateRequest(f, "scene.json", "out.cbtf", "nmf");
  EXPECT_DOUBLE_EQ(s.f("beta"), 0.9);
  EXPECT_EQ(s.i("max_rank"), 4);
  EXPECT_EQ(s.s("memory_budget"), "4G");  // the simulation's own budget, not the compressor's
  EXPECT_EQ(s.s("compress"), "nmf");
  EXPECT_DOUBLE_EQ(s.f("target_ratio"), f.targetRatio);
  // A raw simulation carries no codec.
  EXPECT_EQ(simulateRequest(f, "scene.json", "out.btf", "").s("compress"), "");
}

// The Jobs panel edits every option through the one ParamDecl widget: an option's value, as the
// widget holds it, goes back into the request as the same value (no digit lost, ints stay ints,
// flags and choices unchanged), for every option of every command.
TEST(JobRequests, EveryOptionRoundTripsThroughTheParamWidgetsValue) {
  int checked = 0;
  for (const auto& c : ops::commands()) {
    ops::Request r(c.name);
    for (const auto& d : c.options) {
      if (!r.has(d.name) || r.text(d.name).empty()) continue;  // unset, or a positional to give
      const auto v = requestValue(r, d);
      ops::Request back(c.name);
      back.set(d.name, paramText(d, v));
      EXPECT_EQ(back.text(d.name), r.text(d.name)) << c.name << " " << d.name;
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
  // A value the widget produced that the declaration refuses keeps the engine's message.
  ops::Request s("simulate");
  const ParamDecl& spp = *s.decl().find("spp");
  EXPECT_EQ(paramText(spp, 2.6), "3");
  EXPECT_EQ(paramText(*s.decl().find("tolerance"), 0.123456789012), "0.123456789");
  const std::string e = test::errorOf([&] { s.set("spp", paramText(spp, 0.0)); });
  EXPECT_NE(e.find("--spp"), std::string::npos) << e;
}
