// The cluster path under a real `mpirun` on localhost (docs/cluster.md): on 3 ranks (more ranks
// than the 2 cores: --oversubscribe) simulate, simulate --compress and compress write the bytes
// one process writes, on two scenes; a rank killed mid-run fails the job with no final file, and
// --resume on a different rank count completes it to identical bytes; mismatched requests and
// binaries and a per-rank budget that does not fit are refused with their reasons; study and
// compare give one process's figures. The btfsim built without MPI writes the same files.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_util.h"

using namespace btf::test;
namespace fs = std::filesystem;

namespace {

// mpirun as root needs its two consent variables (CI runs as root).
const char* kMpiEnv = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 ";
std::string launcher(int ranks) {
  return std::string(BTF_MPIRUN) + " --oversubscribe -np " + std::to_string(ranks);
}
std::string mpirun(int ranks) {
  return kMpiEnv + launcher(ranks);
}

std::string scene(const std::string& name) {
  return sourceDir() + "/resources/scenes/" + name + ".json";
}

// Small runs: 24² texels at 4×8 directions (18 chunks of 32 texels).
const char* kSmall = " --texels 24 --dirs 4x8 -q";
// The byte-equality runs (ten per scene): 16² texels, 8 chunks, still more than twice the 3
// ranks, so no chunk is cut (that case is AChunkCutByViews…).
const char* kSame = " --texels 16 --dirs 4x8 -q";

// Any command line; stdout and stderr in `out`, the exit code returned.
int shell(const std::string& cmd, std::string* out) {
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  size_t n;
  out->clear();
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out->append(buf, n);
  const int status = pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

bool sameFile(const fs::path& a, const fs::path& b) {
  return fs::exists(a) && fs::exists(b) && readFile(a) == readFile(b);
}

}  // namespace

TEST(Cluster, ThreeRanksWriteTheBytesOfOneProcess) {
  const auto dir = tempDir("cluster_same");
  for (const std::string name : {"brick", "spheres"}) {
    std::string out;
    const std::string one = (dir / (name + "_1.btf")).string();
    const std::string three = (dir / (name + "_3.btf")).string();
    ASSERT_EQ(runBtfsim("simulate " + scene(name) + " -o " + one + kSame, &out), 0) << out;
    ASSERT_EQ(
        runBtfsim("simulate " + scene(name) + " -o " + three + kSame + " --json", &out, mpirun(3)),
        0)
        << out;
    EXPECT_TRUE(sameFile(one, three)) << name;
    // The report's cluster figures: 3 ranks, every texel computed once.
    const auto j = nlohmann::json::parse(out.substr(out.find('{')));
    ASSERT_TRUE(j.contains("cluster")) << out;
    EXPECT_EQ(j["cluster"]["ranks"], 3);
    double texels = 0;
    std::vector<double> lights;
    for (const auto& r : j["cluster"]["per_rank"]) {
      EXPECT_GT(r["texels"].get<double>(), 0);
      texels += r["texels"].get<double>();
      // A plain simulation sends only agreements and sums: well under 1 % of what it computed.
      EXPECT_LT(r["communicated_fraction"].get<double>(), 0.01);
      // The network's light solve (both scenes have inter-reflection on): every third light on
      // each rank, the solutions shared apart from the chunks' traffic.
      lights.push_back(r["lights_solved"].get<double>());
      EXPECT_GT(r["gi_share_bytes"].get<double>(), 0);
    }
    EXPECT_DOUBLE_EQ(texels, 16 * 16);
    EXPECT_EQ(lights, (std::vector<double>{11, 11, 10})) << j["cluster"].dump();
    for (const std::string codec : {"nmf", "tensor"}) {
      const std::string s1 = (dir / (name + "_" + codec + "_1.cbtf")).string();
      const std::string s3 = (dir / (name + "_" + codec + "_3.cbtf")).string();
      ASSERT_EQ(runBtfsim("simulate " + scene(name) + " -o " + s1 + kSame + " --compress " + codec,
                          &out),
                0)
          << out;
      ASSERT_EQ(runBtfsim("simulate " + scene(name) + " -o " + s3 + kSame + " --compress " + codec,
                          &out, mpirun(3)),
                0)
          << out;
      EXPECT_TRUE(sameFile(s1, s3)) << name << " simulate --compress " << codec;
      const std::string c1 = (dir / (name + "_" + codec + "_c1.cbtf")).string();
      const std::string c3 = (dir / (name + "_" + codec + "_c3.cbtf")).string();
      ASSERT_EQ(runBtfsim("compress " + one + " -o " + c1 + " -q --codec " + codec, &out), 0)
          << out;
      ASSERT_EQ(
          runBtfsim("compress " + one + " -o " + c3 + " -q --codec " + codec, &out, mpirun(3)), 0)
          << out;
      EXPECT_TRUE(sameFile(c1, c3)) << name << " compress " << codec;
    }
  }
}

// 12² texels are 5 chunks: fewer than twice the 3 ranks, so each chunk is cut into pieces of
// contiguous views, computed on different ranks and gathered on one to be written or encoded.
TEST(Cluster, AChunkCutByViewsOverTheRanksGivesTheBytesOfOneProcess) {
  const auto dir = tempDir("cluster_views");
  const std::string tiny = " --texels 12 --dirs 4x8 -q";
  const std::string one = (dir / "one.btf").string(), three = (dir / "three.btf").string();
  std::string out;
  ASSERT_EQ(runBtfsim("simulate " + scene("brick") + " -o " + one + tiny + " --json", &out), 0)
      << out;
  ASSERT_EQ(nlohmann::json::parse(out.substr(out.find('{')))["chunks"].get<int>(), 5);
  // Not quiet: the plan's notice names the cut. The network's light solutions shared one light
  // a round (11 rounds instead of one): the same bytes.
  ASSERT_EQ(
      runBtfsim("simulate " + scene("brick") + " -o " + three + " --texels 12 --dirs 4x8 --json",
                &out, "BTF_TEST_LIGHT_SHARE_ROUND_BYTES=1 " + mpirun(3)),
      0)
      << out;
  EXPECT_NE(out.find("each chunk is cut into pieces of views"), std::string::npos) << out;
  EXPECT_TRUE(sameFile(one, three));
  // Every rank took a share (none idles with 5 chunks on 3 ranks: 15 pieces), and the shares
  // add up to the tile.
  const auto j = nlohmann::json::parse(out.substr(out.find("\n{") + 1));
  double texels = 0;
  for (const auto& r : j["cluster"]["per_rank"]) {
    EXPECT_GT(r["texels"].get<double>(), 144.0 / 3 / 2) << j["cluster"].dump();
    texels += r["texels"].get<double>();
  }
  EXPECT_NEAR(texels, 144, 1e-9);
  // Streamed into a codec: the owner of a split chunk encodes it whole.
  for (const std::string codec : {"nmf", "tensor"}) {
    const std::string s1 = (dir / (codec + "_1.cbtf")).string();
    const std::string s3 = (dir / (codec + "_3.cbtf")).string();
    ASSERT_EQ(
        runBtfsim("simulate " + scene("spheres") + " -o " + s1 + tiny + " --compress " + codec,
                  &out),
        0)
        << out;
    ASSERT_EQ(
        runBtfsim("simulate " + scene("spheres") + " -o " + s3 + tiny + " --compress " + codec,
                  &out, mpirun(3)),
        0)
        << out;
    EXPECT_TRUE(sameFile(s1, s3)) << codec;
  }
  // A resume with 3 chunks missing (a single process killed after 2), on 3 ranks: the missing
  // chunks are cut by views, the bytes those of the uninterrupted run.
  const std::string r = (dir / "resumed.btf").string();
  EXPECT_NE(runBtfsim("simulate " + scene("brick") + " -o " + r + tiny, &out,
                      "BTF_TEST_ABORT_AFTER_CHUNKS=2"),
            0);
  ASSERT_TRUE(fs::exists(r + ".partial"));
  ASSERT_EQ(runBtfsim("simulate " + scene("brick") + " -o " + r + tiny + " --resume --json", &out,
                      mpirun(3)),
            0)
      << out;
  EXPECT_EQ(nlohmann::json::parse(out.substr(out.find('{')))["chunks_resumed"].get<int>(), 2);
  EXPECT_TRUE(sameFile(one, r));
}

TEST(Cluster, AKilledRankFailsTheJobAndAResumeOnOtherRanksCompletesIt) {
  const auto dir = tempDir("cluster_kill");
  const std::string ref = (dir / "ref.btf").string(), out3 = (dir / "k.btf").string();
  std::string out;
  ASSERT_EQ(runBtfsim("simulate " + scene("brick") + " -o " + ref + kSmall, &out), 0) << out;
  // Rank 1 is killed (SIGKILL) after writing 2 chunks.
  const int rc = runBtfsim(
      "simulate " + scene("brick") + " -o " + out3 + kSmall, &out,
      "BTF_TEST_ABORT_AFTER_CHUNKS=2 BTF_TEST_ABORT_RANK=1 BTF_TEST_ABORT_KILL=1 " + mpirun(3));
  EXPECT_NE(rc, 0);
  // mpirun names the rank and the signal.
  EXPECT_NE(out.find("rank 1"), std::string::npos) << out;
  EXPECT_NE(out.find("signal 9"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(out3));
  EXPECT_TRUE(fs::exists(out3 + ".partial"));
  // Resumed on 2 ranks: the chunks on disk are kept, the rest recomputed, the same bytes.
  ASSERT_EQ(runBtfsim("simulate " + scene("brick") + " -o " + out3 + kSmall + " --resume --json",
                      &out, mpirun(2)),
            0)
      << out;
  const auto j = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_GE(j["chunks_resumed"].get<int>(), 2);
  EXPECT_LT(j["chunks_resumed"].get<int>(), j["chunks"].get<int>());
  EXPECT_TRUE(sameFile(ref, out3));
  EXPECT_FALSE(fs::exists(out3 + ".partial"));
}

TEST(Cluster, MismatchesAndBudgetsAreRefusedWithTheirReasons) {
  const auto dir = tempDir("cluster_refuse");
  const std::string o = (dir / "m.btf").string();
  std::string out;
  const std::string sim = " simulate " + scene("brick") + " -o " + o + kSmall;
  const std::string env = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " +
                          std::string(BTF_MPIRUN) + " --oversubscribe -np 1 " + BTF_BTFSIM + sim +
                          " : -np 1";
  // Rank 1 asks for another sampling.
  EXPECT_NE(runBtfsim(sim + " --spp 2", &out, env), 0);
  EXPECT_NE(out.find("ranks disagree on the request: rank 0"), std::string::npos) << out;
  // Rank 1 runs another build (one byte appended: still a valid executable).
  const fs::path other = dir / "btfsim-other";
  fs::copy_file(BTF_BTFSIM, other);
  { std::ofstream(other, std::ios::app) << 'x'; }
  fs::permissions(other, fs::perms::owner_all);
  EXPECT_NE(shell(env + " " + other.string() + sim, &out), 0);
  EXPECT_NE(out.find("ranks disagree on the btfsim binary"), std::string::npos) << out;
  // A budget each rank cannot meet: the rank and the parts are named.
  EXPECT_NE(runBtfsim(sim.substr(1) + " --memory-budget 1M", &out, mpirun(3)), 0);
  EXPECT_NE(out.find("refusing to start: rank 0 of 3 (the budget is per rank)"), std::string::npos)
      << out;
  EXPECT_NE(out.find("hit maps need"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(o));
  EXPECT_FALSE(fs::exists(o + ".partial"));
}

TEST(Cluster, StudyAndCompareGiveTheFiguresOfOneProcess) {
  const auto dir = tempDir("cluster_study");
  std::string out;
  const std::string st =
      " --texels 8 --dirs 4x8 --spp 0,1 --shadows map --network-voxels 0 "
      "--gather 4 --links 16 --bounces 3,1 --reference-spp 16 --image-paths 2 "
      "--image-spp 1 --codecs nmf,svd,tensor -q --json";
  ASSERT_EQ(runBtfsim("study " + scene("brick") + " -o " + (dir / "s1").string() + st, &out), 0)
      << out;
  const auto a = nlohmann::json::parse(out.substr(out.find('{')));
  ASSERT_EQ(
      runBtfsim("study " + scene("brick") + " -o " + (dir / "s3").string() + st, &out, mpirun(3)),
      0)
      << out;
  const auto b = nlohmann::json::parse(out.substr(out.find('{')));
  ASSERT_EQ(a["configurations"].size(), 3u);
  ASSERT_EQ(a["configurations"].size(), b["configurations"].size());
  for (size_t i = 0; i < a["configurations"].size(); ++i) {
    const auto& x = a["configurations"][i];
    const auto& y = b["configurations"][i];
    EXPECT_EQ(x["config"], y["config"]);
    for (const char* k : {"probe_rel_rmse", "set_rel_rmse", "image_rel_rmse"})
      EXPECT_DOUBLE_EQ(x[k].get<double>(), y[k].get<double>()) << i << " " << k;
  }
  EXPECT_TRUE(fs::exists(dir / "s3" / "study.csv"));
  // The compression study: its base store simulated over the ranks, codec i on rank i mod 3,
  // the rows gathered on rank 0 in their order — the figures of one process.
  ASSERT_EQ(a["compression"].size(), 3u);
  ASSERT_EQ(b["compression"].size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const auto& x = a["compression"][i];
    const auto& y = b["compression"][i];
    EXPECT_EQ(x["codec"], y["codec"]);
    EXPECT_EQ(x["bytes"], y["bytes"]);
    EXPECT_GT(x["relative_rmse"].get<double>(), 0.0);
    for (const char* k : {"ratio", "rmse", "relative_rmse"})
      EXPECT_DOUBLE_EQ(x[k].get<double>(), y[k].get<double>()) << i << " " << k;
  }
  EXPECT_EQ(readFile((dir / "s1" / "compression.csv").string()).substr(0, 20),
            readFile((dir / "s3" / "compression.csv").string()).substr(0, 20));
  // The path-traced references (traced in shares over the three ranks, then allgathered) and
  // every probe value: the same bytes as one process.
  EXPECT_EQ(readFile((dir / "s1" / "probes.csv").string()),
            readFile((dir / "s3" / "probes.csv").string()));
  // compare: the spp-1 and adaptive simulations, on 1 and 3 ranks.
  const std::string p = (dir / "p.btf").string(), q = (dir / "q.btf").string();
  ASSERT_EQ(runBtfsim("simulate " + scene("brick") + " -o " + p + kSmall, &out), 0) << out;
  ASSERT_EQ(runBtfsim("simulate " + scene("brick") + " -o " + q + kSmall + " --spp 1", &out), 0)
      << out;
  ASSERT_EQ(runBtfsim("compare " + p + " " + q + " -q --json", &out), 0) << out;
  const auto c1 = nlohmann::json::parse(out.substr(out.find('{')));
  ASSERT_EQ(runBtfsim("compare " + p + " " + q + " -q --json", &out, mpirun(3)), 0) << out;
  const auto c3 = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_NEAR(c1["relative_rmse"].get<double>(), c3["relative_rmse"].get<double>(),
              1e-12 * c1["relative_rmse"].get<double>());
  EXPECT_GT(c1["relative_rmse"].get<double>(), 0.01);  // different samplings do differ
  EXPECT_EQ(c1["worst_texels"], c3["worst_texels"]);
  // A damaged chunk in the last rank's share: every rank stops with that rank's message.
  const std::string bad = (dir / "bad.btf").string();
  fs::copy_file(p, bad);
  {
    std::fstream f(bad, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-100, std::ios::end);
    f.put('\x5a');
  }
  EXPECT_NE(runBtfsim("compare " + p + " " + bad + " -q", &out, mpirun(3)), 0);
  EXPECT_NE(out.find("rank 2 of 3"), std::string::npos) << out;
  EXPECT_NE(out.find("checksum mismatch"), std::string::npos) << out;
}

TEST(Cluster, TheBuildWithoutMpiWritesTheSameFile) {
  const auto dir = tempDir("cluster_nompi");
  const std::string a = (dir / "a.btf").string(), b = (dir / "b.btf").string();
  std::string out;
  ASSERT_EQ(runBtfsim("simulate " + scene("vgrooves") + " -o " + a + kSmall, &out), 0) << out;
  ASSERT_EQ(
      shell(std::string(BTF_BTFSIM_NOMPI) + " simulate " + scene("vgrooves") + " -o " + b + kSmall,
            &out),
      0)
      << out;
  EXPECT_TRUE(sameFile(a, b));
}

TEST(Cluster, TheSlurmScriptsRunUnderAStandInLauncher) {
  // Slurm's daemons are not on this machine: the scripts run with the variables srun and
  // sbatch set (SLURM_CPUS_PER_TASK, SLURM_ARRAY_TASK_ID) and mpirun in place of srun.
  const auto dir = tempDir("cluster_slurm");
  std::string out;
  const std::string ref = (dir / "ref.btf").string(), refc = (dir / "ref.cbtf").string();
  ASSERT_EQ(runBtfsim("simulate " + scene("brick") + " -o " + ref + kSmall, &out), 0) << out;
  ASSERT_EQ(runBtfsim("compress " + ref + " -o " + refc + " -q --codec nmf", &out), 0) << out;
  const std::string env = kMpiEnv + std::string("BTFSIM=") + BTF_BTFSIM +
                          " SLURM_CPUS_PER_TASK=1 SRUN='" + launcher(2) + "' ";
  const std::string slurm = sourceDir() + "/scripts/slurm/";
  const std::string o = (dir / "s.btf").string();
  ASSERT_EQ(shell(env + "CODEC=nmf bash " + slurm + "simulate.sbatch " + scene("brick") + " " + o +
                      " --texels 24 --dirs 4x8",
                  &out),
            0)
      << out;
  EXPECT_TRUE(sameFile(ref, o));
  EXPECT_TRUE(sameFile(refc, (dir / "s.cbtf").string()));
  // Without its arguments: the usage, and a failure.
  EXPECT_NE(shell(env + "bash " + slurm + "simulate.sbatch", &out), 0);
  EXPECT_NE(out.find("usage:"), std::string::npos) << out;
  // Array task 1 of a list simulates the list's second scene.
  {
    std::ofstream list(dir / "scenes.txt");
    list << "# variants\n" << scene("vgrooves") << "\n\n" << scene("brick") << "\n";
  }
  ASSERT_EQ(shell("BTFSIM=" + std::string(BTF_BTFSIM) + " SLURM_ARRAY_TASK_ID=1 bash " + slurm +
                      "batch.sbatch " + (dir / "scenes.txt").string() + " " +
                      (dir / "batch").string() + " --texels 24 --dirs 4x8",
                  &out),
            0)
      << out;
  EXPECT_TRUE(sameFile(ref, dir / "batch" / "brick.btf"));
  EXPECT_NE(
      shell("BTFSIM=" + std::string(BTF_BTFSIM) + " SLURM_ARRAY_TASK_ID=7 bash " + slurm +
                "batch.sbatch " + (dir / "scenes.txt").string() + " " + (dir / "batch").string(),
            &out),
      0);
  EXPECT_NE(out.find("has no scene for array task 7"), std::string::npos) << out;
}
