// Multi-resolution BTFs (docs/mip.md): the texel levels are box averages of the level above
// (exactly, odd sizes too) ending in the tile average; the 1×1 level is the texel-averaged aBRDF
// the path tracer measures; a pyramid of planted low-rank texels is coded exactly by the tensor
// codec with every level's error reported; the header's level table is checked on reading.
#include <btf/compress/mip.h>
#include <btf/core/error.h>
#include <btf/core/format.h>
#include <btf/core/run_context.h>
#include <btf/ops/ops.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "synthetic.h"
#include "test_util.h"

namespace btf {
namespace {

using test::syntheticInfo;
using test::syntheticValues;
using test::tempDir;
using test::writeRaw;

TEST(Mip, LevelGeometryHalvesEachAxisDownToOneTexel) {
  const auto L = mipLevels(8, 6);
  ASSERT_EQ(L.size(), 4u);
  EXPECT_EQ(L[1], (MipLevel{4, 3, 48}));
  EXPECT_EQ(L[2], (MipLevel{2, 2, 60}));
  EXPECT_EQ(L[3], (MipLevel{1, 1, 64}));
  EXPECT_EQ(pyramidTexels(L), 65);
  EXPECT_EQ(mipLevels(1, 1).size(), 1u);
  EXPECT_EQ(mipLevels(5, 1).back(), (MipLevel{1, 1, 5 + 3 + 2}));
  // Boxes: weights sum to one and every fine texel is covered by total weight m/n.
  for (auto [n, m] : {std::pair{6, 3}, {3, 2}, {5, 3}, {7, 4}, {1, 1}}) {
    const auto taps = boxTaps(n, m);
    std::vector<double> cover(size_t(n), 0.0);
    for (const auto& t : taps) {
      double s = 0;
      for (const BoxTap& b : t) s += b.weight, cover[size_t(b.index)] += b.weight;
      EXPECT_NEAR(s, 1.0, 1e-15) << n << "->" << m;
    }
    for (double c : cover) EXPECT_NEAR(c, double(m) / n, 1e-15) << n << "->" << m;
  }
  EXPECT_THROW(mipLevels(0, 4), Error);
}

TEST(Mip, LevelsAreBoxAveragesOfTheLevelAboveAndEndInTheTileAverage) {
  // 8 × 6 → 4 × 3 (2×2 averages) → 2 × 2 (rows: a box of 1.5 texels) → 1 × 1.
  const BtfInfo info = syntheticInfo(8, 6, "4x8");
  const std::vector<float> v = syntheticValues(info, {5, 11}, 30.0);
  const auto L = mipLevels(info.nu, info.nv);
  const size_t S = size_t(info.nDirs()) * info.nDirs() * 3;
  const std::vector<float> coarse = buildCoarseLevels(v.data(), info, int(L.size()) - 1);
  ASSERT_EQ(coarse.size(), size_t(pyramidTexels(L) - info.texels()) * S);
  auto at = [&](int k, int u, int w) -> const float* {
    if (k == 0) return v.data() + (size_t(w) * size_t(info.nu) + size_t(u)) * S;
    return coarse.data() + (size_t(L[size_t(k)].first - info.texels()) +
                            size_t(w) * size_t(L[size_t(k)].nu) + size_t(u)) *
                               S;
  };
  // Level 1: the plain mean of each 2 × 2 block, independently computed.
  for (int w = 0; w < 3; ++w)
    for (int u = 0; u < 4; ++u)
      for (size_t i = 0; i < S; ++i) {
        const double mean = (double(at(0, 2 * u, 2 * w)[i]) + at(0, 2 * u + 1, 2 * w)[i] +
                             at(0, 2 * u, 2 * w + 1)[i] + at(0, 2 * u + 1, 2 * w + 1)[i]) /
                            4;
        ASSERT_NEAR(at(1, u, w)[i], mean, 1e-6 * (std::abs(mean) + 1e-6));
      }
  // Level 2 from level 1: columns pair up; the 3 rows split 1 + ½ | ½ + 1 (weights 2/3, 1/3).
  for (int w = 0; w < 2; ++w)
    for (int u = 0; u < 2; ++u)
      for (size_t i = 0; i < S; ++i) {
        double m = 0;
        for (int du = 0; du < 2; ++du) {
          const double full = at(1, 2 * u + du, w == 0 ? 0 : 2)[i];
          const double half = at(1, 2 * u + du, 1)[i];
          m += (2.0 / 3) * full + (1.0 / 3) * half;
        }
        m /= 2;
        ASSERT_NEAR(at(2, u, w)[i], m, 1e-6 * (std::abs(m) + 1e-6));
      }
  // The last level is the mean over every texel: the tile's texel-averaged aBRDF.
  for (size_t i = 0; i < S; ++i) {
    double m = 0;
    for (int64_t t = 0; t < info.texels(); ++t) m += v[size_t(t) * S + i];
    m /= double(info.texels());
    ASSERT_NEAR(at(3, 0, 0)[i], m, 2e-6 * (std::abs(m) + 1e-6));
  }
  // Through a store: the same values, whichever way a level is read.
  const auto dir = tempDir("mip_levels");
  const std::string raw = writeRaw((dir / "a.btf").string(), info, v);
  const auto l2 = openBtfLevel(raw, 2);
  ASSERT_EQ(l2->info().nu, 2);
  ASSERT_EQ(l2->info().nv, 2);
  std::vector<float> buf(S);
  l2->texel(3, buf.data());
  for (size_t i = 0; i < S; ++i) ASSERT_EQ(buf[i], std::max(0.f, at(2, 1, 1)[i]));
  try {
    openBtfLevel(raw, 4);
    FAIL() << "level 4 of a 4-level BTF accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("its levels are 0..3"), std::string::npos) << e.what();
  }
  // The budget is checked before the levels are built.
  EXPECT_THROW(openBtfLevel(raw, 1, 1000), Error);
}

TEST(Mip, VisibilityLevelsKeepTheHighestReliefOfTheirBox) {
  // 2 directions × 4 × 2 texels: coverage and height vary; the 2 × 1 level keeps each box's
  // largest coverage and the highest covered height (an uncovered texel's height is ignored).
  const std::vector<float> vmf = {// direction 0, row 0: (cov, h) × 4, then row 1
                                  1, 0.1f, 0, 9.f, 0.5f, 0.3f, 1, 0.2f,  //
                                  1, 0.4f, 1, 0.05f, 0, 0, 0, 0,         //
                                  // direction 1: nothing covered
                                  0, 1, 0, 2, 0, 3, 0, 4, 0, 5, 0, 6, 0, 7, 0, 8};
  const auto lv = vmfLevels(vmf, 2, 4, 2, 2);
  ASSERT_EQ(lv.size(), 2u);
  ASSERT_EQ(lv[0].size(), 2u * 2 * 1 * 2);
  EXPECT_EQ(lv[0][0], 1.f);   // box (0..1, 0..1) of direction 0
  EXPECT_EQ(lv[0][1], 0.4f);  // the 9 under zero coverage does not count
  EXPECT_EQ(lv[0][2], 1.f);   // box (2..3, 0..1)
  EXPECT_EQ(lv[0][3], 0.3f);
  EXPECT_EQ(lv[0][4], 0.f);  // direction 1: nothing covered anywhere
  EXPECT_EQ(lv[0][5], 0.f);
  EXPECT_EQ(lv[1][0], 1.f);  // 1 × 1
  EXPECT_EQ(lv[1][1], 0.4f);
}

TEST(Mip, PlantedLowRankPyramidIsCodedExactlyWithEveryLevelsError) {
  // Every texel Σ_j a_tj f_j(view) g_j(light) · colour_t with shared f_j, g_j: box averages stay
  // in the same span, so one cluster of small ranks holds every level.
  const BtfInfo info = syntheticInfo(8, 8, "4x8");
  const std::vector<float> v = syntheticValues(info, {9});
  const auto dir = tempDir("mip_planted");
  const std::string raw = writeRaw((dir / "a.btf").string(), info, v);
  CodecSettings s;
  s.codec = "tensor";
  s.colour = "rgb";
  s.half = false;
  s.clusters = 1;
  s.targetRmse = 1e-4;
  PyramidReport rep;
  const CompressedBtf c = compressPyramid(raw, s, false, nullptr, &rep);
  ASSERT_EQ(c.levels, mipLevels(8, 8));
  ASSERT_EQ(rep.levels.size(), 4u);
  const auto stats = nlohmann::json::parse(c.statsJson);
  ASSERT_EQ(stats.at("levels").size(), 4u);
  const std::string out = (dir / "a.cbtf").string();
  writeCompressed(out, c);
  for (int k = 0; k < 4; ++k) {
    SCOPED_TRACE(k);
    // The reported error is what comparing the level with the raw store's level gives.
    const auto ref = openBtfLevel(raw, k), got = openBtfLevel(out, k);
    EXPECT_EQ(got->kind(), "tensor");
    EXPECT_EQ(got->info().nu, mipLevels(8, 8)[size_t(k)].nu);
    const ErrorReport e = compareBtfs(*ref, *got, false, 0);
    EXPECT_LT(e.relRmse, 1e-4);
    EXPECT_NEAR(rep.levels[size_t(k)].relRmse, e.relRmse, 1e-6);
    EXPECT_NEAR(stats["levels"][size_t(k)]["relative_rmse"].get<double>(), e.relRmse, 1e-6);
  }
  // A header whose level table does not follow from its texel grid is refused by name.
  CompressedBtf bad = c;
  bad.levels[1].nu = 3;
  const std::string badPath = (dir / "bad.cbtf").string();
  writeCompressed(badPath, bad);
  try {
    readCompressed(badPath);
    FAIL() << "a wrong level table was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/levels/1: must be 4×4 texels from texel 64"),
              std::string::npos)
        << e.what();
  }
}

TEST(Mip, TheLastLevelIsTheTexelAveragedBrdfOfThePathTracer) {
  const auto dir = tempDir("mip_brdf");
  const auto scene = dir / "boxes.json";
  std::ofstream(scene) << R"({
    "btfscene": 1, "name": "boxes", "tile": {"size": [1.0, 1.0]},
    "materials": {"white": {"type": "lambert", "albedo": [0.6, 0.6, 0.6]}},
    "parts": [{"name": "ground", "type": "plane", "material": "white"},
              {"name": "box", "type": "box", "material": "white",
               "center": [0.5, 0.5, 0.2], "size": [0.4, 0.4, 0.4]}],
    "simulation": {"texels": [8, 8], "directions": "axis-grid", "grid": [3, 8]}
  })";
  RunContext ctx;
  ctx.progress = false;
  const std::string btf = (dir / "boxes.btf").string();
  ops::run(ops::Request("simulate")
               .set("scene", scene.string())
               .set("output", btf)
               .set("spp", "8")
               .setFlag("quiet", true),
           ctx);
  const auto top = openBtfLevel(btf, 3);
  ASSERT_EQ(top->info().texels(), 1);
  const auto& dirs = top->info().dirsDeg;
  // Pairs of the set: near normal, oblique, across the azimuths.
  ASSERT_EQ(dirs.size(), 17u);  // the pole and two rings of 8
  const int pairs[][2] = {{0, 0}, {2, 9}, {13, 5}, {16, 4}, {7, 12}};
  std::string list;
  for (const auto& p : pairs)
    list += (list.empty() ? "" : ";") + format("%.9g,%.9g,%.9g,%.9g", dirs[size_t(p[1])][0],
                                               dirs[size_t(p[1])][1], dirs[size_t(p[0])][0],
                                               dirs[size_t(p[0])][1]);
  const ops::Report r = ops::run(ops::Request("brdf")
                                     .set("scene", scene.string())
                                     .set("pair", list)
                                     .set("spp", "96")
                                     .setFlag("quiet", true),
                                 ctx);
  for (size_t k = 0; k < std::size(pairs); ++k) {
    const auto v = top->value(0, pairs[k][0], pairs[k][1]);
    const double pt = r.json["pairs"][k]["abrdf"][0].get<double>();
    EXPECT_NEAR(v[0], pt, 0.03 * pt + 1e-3) << "view " << pairs[k][0] << " light " << pairs[k][1];
  }
}

}  // namespace
}  // namespace btf
