// btfsim compress / compare / export / simulate --compress end to end on a simulated scene.
#include <btf/compress/cbtf.h>
#include <btf/compress/compress.h>
#include <btf/store/btf_store.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "test_util.h"

namespace btf {
namespace {

std::string scenePath(const std::string& n) {
  return test::sourceDir() + "/resources/scenes/" + n + ".json";
}

TEST(BtfsimCompress, StreamedSimulationEqualsCompressingTheStoredBtf) {
  const auto dir = test::tempDir("cli_compress");
  const std::string common = scenePath("bumps") + " --texels 8 --dirs 4x8 --spp 1 -q";
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + common + " -o " + (dir / "a.btf").string(), &out), 0)
      << out;
  for (const std::string codec : {"nmf", "svd", "tensor", "neural"}) {
    const std::string extra = codec == "neural" ? " --neural-steps 100" : "";
    const std::string file = (dir / (codec + "_file.cbtf")).string();
    const std::string streamed = (dir / (codec + "_stream.cbtf")).string();
    ASSERT_EQ(test::runBtfsim("compress " + (dir / "a.btf").string() + " -o " + file + " --codec " +
                                  codec + extra + " --train-texels 20 --json -q --compare",
                              &out),
              0)
        << out;
    const auto j = nlohmann::json::parse(out.substr(out.find('{')));
    EXPECT_GT(j.at("ratio").get<double>(), 1.0);
    const double rel = j.at("error").at("relative_rmse").get<double>();
    EXPECT_GT(rel, 0.0);
    EXPECT_LT(rel, 1.0);
    ASSERT_EQ(test::runBtfsim("simulate " + common + " -o " + streamed + " --compress " + codec +
                                  extra + " --train-texels 20",
                              &out),
              0)
        << out;
    EXPECT_FALSE(std::filesystem::exists(dir / (codec + "_stream.cbtf.partial")));
    const CompressedBtf a = readCompressed(file), b = readCompressed(streamed);
    ASSERT_EQ(a.arrays.size(), b.arrays.size());
    for (size_t i = 0; i < a.arrays.size(); ++i)
      EXPECT_TRUE(a.arrays[i].data == b.arrays[i].data) << codec << " " << a.arrays[i].name;
    // compare: identical files have zero error; raw vs compressed matches compress --compare.
    ASSERT_EQ(test::runBtfsim("compare " + file + " " + streamed + " --json -q", &out), 0) << out;
    EXPECT_EQ(nlohmann::json::parse(out.substr(out.find('{'))).at("rmse").get<double>(), 0.0);
    ASSERT_EQ(test::runBtfsim("compare " + (dir / "a.btf").string() + " " + file + " -q --maps " +
                                  (dir / (codec + "_maps")).string(),
                              &out),
              0)
        << out;
    EXPECT_NE(out.find("relative RMSE"), std::string::npos);
    ASSERT_EQ(
        test::runBtfsim("compare " + (dir / "a.btf").string() + " " + file + " -q --json", &out),
        0);
    EXPECT_NEAR(nlohmann::json::parse(out.substr(out.find('{'))).at("relative_rmse").get<double>(),
                rel, 1e-12);
    EXPECT_TRUE(std::filesystem::exists(dir / (codec + "_maps") / "texel_rmse.png"));
    EXPECT_TRUE(std::filesystem::exists(dir / (codec + "_maps") / "direction_rmse.exr"));
  }
  // Exports run from a compressed file too.
  ASSERT_EQ(test::runBtfsim("export " + (dir / "nmf_file.cbtf").string() + " --format merl -q -o " +
                                (dir / "a.binary").string(),
                            &out),
            0)
      << out;
  EXPECT_EQ(std::filesystem::file_size(dir / "a.binary"), 34992012u);
}

// Every .cbtf carries the visibility map of its source (8-bit coded): compress, compress --mip
// and simulate --compress write the same map, within its quantisation of the store's; render's
// mapped mode needs no raw store beside it and draws what the store's full map draws; a damaged
// map is refused naming it.
TEST(BtfsimCompress, ACompressedFileCarriesItsVisibilityMapAndRendersAlone) {
  const auto dir = test::tempDir("cli_vmf");
  const std::string raw = (dir / "a.btf").string(), common = scenePath("brick") +
                                                             " --texels 8 --dirs 4x8 --spp 1 -q";
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + common + " -o " + raw, &out), 0) << out;
  const std::string t = (dir / "t.cbtf").string(), m = (dir / "m.cbtf").string(),
                    s = (dir / "s.cbtf").string();
  ASSERT_EQ(test::runBtfsim("compress " + raw + " -o " + t + " --target-ratio 20 --json -q", &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(out.substr(out.find('{')));
  ASSERT_EQ(test::runBtfsim("compress " + raw + " -o " + m + " --mip -q", &out), 0) << out;
  ASSERT_EQ(test::runBtfsim("simulate " + common + " -o " + s + " --compress tensor --target-ratio 20",
                            &out),
            0)
      << out;
  const std::vector<float> full = BtfReader(raw).readVmfAll();
  const CompressedBtf ct = readCompressed(t);
  EXPECT_EQ(ct.codec, "tensor");  // the default codec
  ASSERT_TRUE(ct.hasVmf());
  EXPECT_EQ(j.at("vmf_bytes").get<uint64_t>(), ct.vmfCoded.size());
  EXPECT_EQ(j.at("compressed_bytes").get<uint64_t>(), ct.fileBytes());
  const std::vector<float> coded = ct.vmf();
  ASSERT_EQ(coded.size(), full.size());
  float lo = full[1], hi = full[1];
  for (size_t k = 1; k < full.size(); k += 2) lo = std::min(lo, full[k]), hi = std::max(hi, full[k]);
  ASSERT_GT(hi, lo);  // a relief: the depths vary
  for (size_t k = 0; k < full.size(); k += 2) {
    ASSERT_NEAR(coded[k], full[k], 1.0 / 510 + 1e-6) << "coverage " << k / 2;
    ASSERT_NEAR(coded[k + 1], full[k + 1], (hi - lo) / 510 + 1e-6) << "depth " << k / 2;
  }
  EXPECT_TRUE(readCompressed(m).vmfCoded == ct.vmfCoded);
  // Streamed with a ratio target: the map's bytes are reserved in the same budget, so the
  // arrays are the same as well.
  const CompressedBtf cs = readCompressed(s);
  EXPECT_TRUE(cs.vmfCoded == ct.vmfCoded);
  ASSERT_EQ(cs.arrays.size(), ct.arrays.size());
  for (size_t i = 0; i < cs.arrays.size(); ++i)
    EXPECT_TRUE(cs.arrays[i].data == ct.arrays[i].data) << cs.arrays[i].name;
  // The mapped render from the file alone, then with the store's full-precision map.
  const std::string own = (dir / "own.exr").string(), full1 = (dir / "full.exr").string();
  ASSERT_EQ(test::runBtfsim("render " + t + " -o " + own + " --size 48 --spp 1 -q", &out), 0) << out;
  ASSERT_EQ(test::runBtfsim("render " + t + " --vmf " + raw + " -o " + full1 +
                                " --size 48 --spp 1 -q",
                            &out),
            0)
      << out;
  ASSERT_EQ(test::runBtfsim("render " + t + " -o " + own + " --size 48 --spp 1 -q --json "
                                "--reference " + full1,
                            &out),
            0)
      << out;
  const auto e = nlohmann::json::parse(out.substr(out.find('{'))).at("images").at(0).at("error");
  EXPECT_LT(e.at("rel_rmse").get<double>(), 0.03) << e.dump();
  // A damaged map: a flipped byte in its block (the file's last bytes).
  std::string bytes = test::readFile(t);
  bytes[bytes.size() - 2] ^= 0x20;
  std::ofstream(dir / "bad.cbtf", std::ios::binary) << bytes;
  EXPECT_NE(test::runBtfsim("info " + (dir / "bad.cbtf").string(), &out), 0);
  EXPECT_NE(out.find("checksum mismatch in the visibility map"), std::string::npos) << out;
}

TEST(BtfsimCompress, ARatioTheCodecCannotSpendIsAWarningNamingItsLimits) {
  // 12² texels of 32 directions at 1:1.1: every rank reaches its cap long before the bytes are
  // spent; the file is written and the warning says what held it, even with -q.
  const auto dir = test::tempDir("cli_ratio_limit");
  const std::string raw = (dir / "a.btf").string();
  std::string out;
  ASSERT_EQ(test::runBtfsim(
                "simulate " + scenePath("bumps") + " --texels 12 --dirs 4x8 -q -o " + raw, &out),
            0)
      << out;
  ASSERT_EQ(test::runBtfsim("compress " + raw + " -o " + (dir / "a.cbtf").string() +
                                " --codec tensor --target-ratio 1.1 -q",
                            &out),
            0)
      << out;
  EXPECT_NE(out.find("warning: ratio 1:2 instead of the 1:1.1 asked"), std::string::npos) << out;
  EXPECT_NE(out.find("texel ranks at their cap"), std::string::npos) << out;
  EXPECT_NE(out.find("at the view/light caps (32)"), std::string::npos) << out;
}

TEST(BtfsimCompress, BadInputsAreClearErrors) {
  const auto dir = test::tempDir("cli_compress_err");
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + scenePath("bumps") + " --texels 4 --dirs 4x8 -q -o " +
                                (dir / "a.btf").string(),
                            &out),
            0);
  ASSERT_EQ(test::runBtfsim("simulate " + scenePath("bumps") + " --texels 5 --dirs 4x8 -q -o " +
                                (dir / "b.btf").string(),
                            &out),
            0);
  std::ofstream(dir / "junk.cbtf") << "BTFCOMP1 but nothing else";
  const std::string a = (dir / "a.btf").string();
  struct Case {
    std::string args, expect;
  } cases[] = {
      {"compress " + a + " -o x.cbtf --codec jpeg",
       "--codec: must be one of nmf, svd, perview, lpca, tensor, neural (got 'jpeg')"},
      {"compress " + a + " -o x.cbtf --target-rmse 0.05 --target-ratio 300",
       "give one of them, not both"},
      {"compress " + a + " -o x.cbtf --beta 0", "--beta: must be in (0, 1]"},
      {"compress " + a + " -o x.cbtf --beta-mode median",
       "--beta-mode: must be one of energy, singular (got 'median')"},
      {"compress missing.btf -o x.cbtf", "missing.btf"},
      {"compare " + a + " " + (dir / "b.btf").string(), "texel grids differ"},
      {"compare " + a + " " + (dir / "junk.cbtf").string(), "junk.cbtf: truncated file"},
      {"export " + a + " --format obj -o x",
       "--format: must be one of ubo2003, ubo2014, merl, rgl-bsdf (got 'obj')"},
      {"compress " + a + " -o x.cbtf --codec svd --memory-budget 1M",
       "refusing to start: compressing"},
      {"info " + (dir / "junk.cbtf").string(), "truncated file"},
      {"simulate " + scenePath("bumps") + " --texels 4 -q -o x.cbtf --compress zip",
       "unknown codec 'zip'"},
  };
  for (const auto& c : cases) {
    EXPECT_NE(test::runBtfsim(c.args, &out), 0) << c.args;
    EXPECT_NE(out.find(c.expect), std::string::npos) << c.args << "\n" << out;
  }
}

}  // namespace
}  // namespace btf

namespace btf {
namespace {

TEST(BtfsimCompress, SimulateCompressMipEqualsCompressMipOfTheStoreAndLeavesNoStore) {
  // docs/mip.md: the pyramid of a simulation written in one command is the pyramid of its store,
  // byte for byte, and the temporary level-0 store is gone; levels are read by --level.
  const auto dir = test::tempDir("cli_compress_mip");
  const std::string common = scenePath("bumps") + " --texels 8 --dirs 4x8 --spp 1 -q";
  const std::string raw = (dir / "a.btf").string(), file = (dir / "file.cbtf").string(),
                    streamed = (dir / "stream.cbtf").string();
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + common + " -o " + raw, &out), 0) << out;
  ASSERT_EQ(test::runBtfsim("compress " + raw + " -o " + file + " --codec tensor --mip -q", &out),
            0)
      << out;
  ASSERT_EQ(test::runBtfsim(
                "simulate " + common + " -o " + streamed + " --compress tensor --mip --json", &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(out.substr(out.find('{')));
  ASSERT_EQ(j.at("levels").size(), 4u);  // 8², 4², 2², 1²
  EXPECT_FALSE(std::filesystem::exists(streamed + ".level0.btf"));
  EXPECT_FALSE(std::filesystem::exists(streamed + ".level0.btf.partial"));
  EXPECT_EQ(test::readFile(file), test::readFile(streamed));
  ASSERT_EQ(test::runBtfsim("compare " + raw + " " + streamed + " --level 2 --json -q", &out), 0)
      << out;
  const auto e = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(e.at("level"), 2);
  EXPECT_NEAR(e.at("relative_rmse").get<double>(),
              j.at("levels").at(2).at("relative_rmse").get<double>(), 1e-9);
  // Without --compress there is nothing to make a pyramid of.
  ASSERT_NE(
      test::runBtfsim("simulate " + common + " -o " + (dir / "b.btf").string() + " --mip", &out),
      0);
  EXPECT_NE(out.find("--mip: give --compress CODEC too"), std::string::npos) << out;
}

TEST(BtfsimCompress, StudySweepsCodecsAndComponents) {
  const auto dir = test::tempDir("cli_compress_study");
  std::string out;
  ASSERT_EQ(test::runBtfsim("study " + scenePath("bumps") + " -o " + dir.string() +
                                " -q --texels 6 --dirs 4x8 --spp 1 --shadows map "
                                "--network-voxels 0 --gather 4 --links 16 --bounces 1 "
                                "--reference-spp 8 --codecs nmf,svd,tensor --components 1,4 "
                                "--mip",
                            &out),
            0)
      << out;
  const std::string csv = test::readFile(dir / "compression.csv");
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);                          // header
  std::map<std::string, std::vector<double>> rel;  // codec → relative RMSE by components
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::string cell;
    bool quoted = false;
    for (char ch : line) {
      if (ch == '"')
        quoted = !quoted;
      else if (ch == ',' && !quoted)
        f.push_back(cell), cell.clear();
      else
        cell += ch;
    }
    f.push_back(cell);
    ASSERT_EQ(f.size(), 13u) << line;
    rel[f[0]].push_back(std::stod(f[8]));
  }
  ASSERT_EQ(rel["nmf"].size(), 2u);
  ASSERT_EQ(rel["svd"].size(), 2u);
  ASSERT_EQ(rel["tensor"].size(), 2u);
  EXPECT_LT(rel["tensor"][1], rel["tensor"][0]);  // ranks capped at 4 instead of 1
  // More components never fit worse (same training, nested bases).
  EXPECT_LE(rel["svd"][1], rel["svd"][0] + 1e-9);
  EXPECT_LE(rel["nmf"][1], rel["nmf"][0] + 1e-3);
  EXPECT_FALSE(std::filesystem::exists(dir / "base.btf"));
  EXPECT_NE(test::readFile(dir / "compression.md").find("| svd |"), std::string::npos);
  EXPECT_NE(test::readFile(dir / "compression.md").find("| tensor |"), std::string::npos);
  // --mip: each setting's pyramid, 6² → 3² → 2² → 1², every level's error (finite, < 100 %).
  std::istringstream pm(test::readFile(dir / "pyramid.md"));
  int rows = 0;
  while (std::getline(pm, line)) {
    if (line.rfind("| nmf |", 0) != 0 && line.rfind("| svd |", 0) != 0 &&
        line.rfind("| tensor |", 0) != 0)
      continue;
    ++rows;
    const std::string errs = line.substr(line.rfind("| ", line.size() - 3) + 2);
    std::istringstream e(errs);
    std::string tok;
    int levels = 0;
    while (e >> tok)
      if (tok != "/" && tok != "%" && tok != "|") {
        const double v = std::stod(tok);
        EXPECT_TRUE(v >= 0 && v < 100) << line;
        ++levels;
      }
    EXPECT_EQ(levels, 4) << line;
  }
  EXPECT_EQ(rows, 6);
}

}  // namespace
}  // namespace btf
