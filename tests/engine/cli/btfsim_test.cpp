// btfsim end to end: errors are one line with a nonzero exit; commands produce what they say.
#include <btf/core/error.h>
#include <btf/core/math.h>
#include <btf/io/image_io.h>
#include <btf/ops/ops.h>
#include <btf/store/btf_store.h>
#include <gtest/gtest.h>

#include <fstream>

#include "test_util.h"

namespace btf {
namespace {

std::string scenePath(const std::string& n) {
  return test::sourceDir() + "/resources/scenes/" + n + ".json";
}

TEST(Btfsim, BadArgumentsAreOneLineErrorsWithNonzeroExit) {
  const auto dir = test::tempDir("cli_err");
  std::ofstream(dir / "broken.json") << "{\"btfscene\": 1,\n \"parts\": [}\n";
  struct Case {
    std::string args, expect;
  } cases[] = {
      {"simulate " + (dir / "broken.json").string() + " -o x.btf -q",
       "broken.json:2:12: JSON syntax error near"},
      {"simulate " + scenePath("brick") + " -o x.btf -q --dirs bonn80",
       "unknown direction set 'bonn80'"},
      {"simulate " + scenePath("brick") + " -o x.btf -q --texels 0", "invalid --texels '0'"},
      {"simulate " + scenePath("brick") + " -o x.btf -q --texels -4x4", "invalid --texels"},
      {"simulate " + scenePath("brick") + " -o x.btf -q --shadows soft",
       "--shadows: must be one of map, rays (got 'soft')"},
      {"simulate " + scenePath("brick") + " -o x.btf -q --bias nan",
       "--bias: expected a finite number, got 'nan'"},
      {"simulate " + scenePath("brick") + " -o x.btf -q --memory-budget 10Q", "unknown unit 'Q'"},
      {"simulate missing.json -o x.btf", "missing.json: scene file not found"},
      {"simulate " + scenePath("brick") +
           " -o x.btf -q --texels 64 --dirs 16x32 --memory-budget 100M",
       "refusing to start: memory budget"},
      {"brdf " + scenePath("brick") + " --pair 95,0,0,0", "θ must be in [0, 89.99] degrees"},
      {"brdf " + scenePath("brick") + " --pair 10,0,0", "expected θi,φi,θo,φo"},
      {"info " + (dir / "broken.json").string(), "not a BTF store"},
      // The error names the option the user gave, not another that shares its parser.
      {"render " + scenePath("brick") + " -o x.exr -q --mode exact --size 100000",
       "invalid --size '100000': each count must be between 1 and 16384"},
      {"render " + scenePath("brick") + " -o x.exr -q --mode exact --size 64y",
       "invalid --size '64y'"},
  };
  for (const auto& c : cases) {
    std::string out;
    const int rc = test::runBtfsim(c.args, &out);
    SCOPED_TRACE(c.args);
    EXPECT_NE(rc, 0);
    EXPECT_NE(out.find("btfsim: error: "), std::string::npos) << out;
    EXPECT_NE(out.find(c.expect), std::string::npos) << out;
  }
}

TEST(Btfsim, SimulateSliceInfoAndBrdfAgree) {
  const auto dir = test::tempDir("cli_flow");
  const std::string btf = (dir / "flat.btf").string();
  std::ofstream(dir / "flat.json")
      << R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": [0.5, 0.25, 1]}},
    "parts": [{"type": "plane", "material": "m"}]})";
  std::string out;
  ASSERT_EQ(
      test::runBtfsim(
          "simulate " + (dir / "flat.json").string() + " -o " + btf + " --texels 4x3 --json", &out),
      0)
      << out;
  EXPECT_NE(out.find("\"abrdf_evaluations_per_second\""), std::string::npos);
  EXPECT_NE(out.find("estimate: "), std::string::npos);
  ASSERT_EQ(test::runBtfsim("info " + btf, &out), 0) << out;
  EXPECT_NE(out.find("all verified"), std::string::npos);
  // Spatial EXR slice holds aBRDF itself: ρ/π.
  ASSERT_EQ(
      test::runBtfsim(
          "slice " + btf + " --view 20,30 --light 50,200 -o " + (dir / "s.exr").string(), &out),
      0)
      << out;
  int w, h;
  auto px = readRgbImage((dir / "s.exr").string(), &w, &h);
  EXPECT_EQ(w, 4);
  EXPECT_EQ(h, 3);
  EXPECT_NEAR(px[0], 0.5 / kPi, 1e-5);
  EXPECT_NEAR(px[1], 0.25 / kPi, 1e-5);
  // PNG: sRGB of π·aBRDF·exposure → albedo 0.5 encodes as 188 (of 255).
  ASSERT_EQ(test::runBtfsim("slice " + btf + " --texel avg --light 30,0 --size 16 -o " +
                                (dir / "h.png").string(),
                            &out),
            0)
      << out;
  px = readRgbImage((dir / "h.png").string(), &w, &h);
  EXPECT_EQ(w, 16);
  EXPECT_NEAR(px[(8 * 16 + 8) * 3] * 255, 188, 1.0);
  EXPECT_EQ(px[0], 0.0f);  // outside the hemisphere disk
  ASSERT_EQ(test::runBtfsim(
                "brdf " + (dir / "flat.json").string() + " --pair 10,0,80,90 --spp 8 --json", &out),
            0)
      << out;
  EXPECT_NE(out.find("0.159154"), std::string::npos) << out;
}

TEST(Btfsim, AMissingImageModuleIsAClearErrorAndCommandsWithoutImagesStillRun) {
  // OpenImageIO is loaded on the first image read or write (btf/io/oiio_module.h): without the
  // module a slice to EXR fails naming where it looked and leaves no file; a simulation, which
  // writes no image, runs as before.
  const auto dir = test::tempDir("cli_no_oiio");
  const std::string btf = (dir / "flat.btf").string(), exr = (dir / "s.exr").string();
  const std::string env = "BTF_OIIO_MODULE=" + (dir / "nowhere.so").string();
  std::ofstream(dir / "flat.json")
      << R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": 0.5}},
    "parts": [{"type": "plane", "material": "m"}]})";
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + (dir / "flat.json").string() + " -o " + btf +
                                " --texels 4 --dirs 4x8 -q",
                            &out, env),
            0)
      << out;
  EXPECT_EQ(test::runBtfsim("slice " + btf + " --view 20,30 --light 50,200 -o " + exr, &out, env),
            1);
  EXPECT_NE(out.find("cannot load the OpenImageIO module libbtf_oiio.so"), std::string::npos)
      << out;
  EXPECT_NE(out.find((dir / "nowhere.so").string() + " (missing)"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(exr));
  // Found where the build puts it: the same slice succeeds.
  EXPECT_EQ(test::runBtfsim("slice " + btf + " --view 20,30 --light 50,200 -o " + exr, &out), 0)
      << out;
  EXPECT_TRUE(std::filesystem::exists(exr));
}

TEST(Btfsim, BrdfReadsPairsFromCsvWithLineErrors) {
  const auto dir = test::tempDir("cli_csv");
  std::ofstream(dir / "p.csv") << "theta_i,phi_i,theta_o,phi_o\n10,0,20,0\n30,0,oops,0\n";
  std::string out;
  EXPECT_NE(
      test::runBtfsim("brdf " + scenePath("brick") + " --pairs " + (dir / "p.csv").string(), &out),
      0);
  EXPECT_NE(out.find("p.csv:3"), std::string::npos) << out;
}

TEST(Btfsim, TexelAndAngleParsers) {
  int a, b;
  ops::parseTexels("64", &a, &b);
  EXPECT_EQ(a, 64);
  EXPECT_EQ(b, 64);
  ops::parseTexels("64x32", &a, &b);
  EXPECT_EQ(b, 32);
  EXPECT_THROW(ops::parseTexels("64y32", &a, &b), Error);
  double t, p;
  ops::parseAnglePair("30,45", "--view", &t, &p);
  EXPECT_EQ(p, 45);
  EXPECT_THROW(ops::parseAnglePair("90,0", "--view", &t, &p), Error);
}

}  // namespace
}  // namespace btf
