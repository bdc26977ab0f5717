// The neural codec (codec_neural.cpp) on constructed BTFs with known values: texels drawn from a
// few analytic BRDFs reconstruct within 1 %, one analytic BRDF decoded between the set's
// directions matches the closed form, the same request writes the same bytes with any thread
// count, damaged tables are refused naming the field, a cancelled or killed training leaves
// nothing, and `compare` against another direction set evaluates the file at its directions.
#include <btf/compress/compress.h>
#include <btf/core/error.h>
#include <btf/core/run_context.h>
#include <btf/directions/direction_set.h>
#include <btf/io/image_io.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tbb/task_arena.h>

#include <cmath>

#include "engine/compress/synthetic.h"
#include "test_util.h"

using namespace btf;
using namespace btf::test;

namespace {

// Three analytic BRDFs (light ω_i, view ω_o): Lambert, Blinn-Phong of exponent 8 with a
// Lambert base, and a retro-reflective lobe; colours differ.
std::array<double, 3> analytic(int kind, const DVec3& wi, const DVec3& wo) {
  const DVec3 h = glm::normalize(wi + wo);
  switch (kind) {
    case 0:
      return {0.7 / M_PI, 0.5 / M_PI, 0.3 / M_PI};
    case 1: {
      const double s = 0.2 / M_PI + 0.6 * std::pow(std::max(0.0, h.z), 8);
      return {s, 0.9 * s, 0.8 * s};
    }
    default: {
      const double r = 0.1 / M_PI + 0.3 * std::pow(std::max(0.0, glm::dot(wi, wo)), 4);
      return {0.6 * r, r, 0.7 * r};
    }
  }
}

// Texel t holds BRDF (t mod 3) scaled by 0.5 + t / T, times cos θ_i (the aBRDF of a flat texel).
std::vector<float> analyticValues(const BtfInfo& info, bool oneKind) {
  const DirectionSet ds = DirectionSet::fromName(info.directionSet);
  const int n = ds.size();
  const int64_t T = info.texels();
  std::vector<float> v(size_t(T) * n * n * 3);
  for (int64_t t = 0; t < T; ++t) {
    const double s = oneKind ? 1.0 : 0.5 + double(t) / double(T);
    for (int o = 0; o < n; ++o)
      for (int l = 0; l < n; ++l) {
        const auto f = analytic(oneKind ? 1 : int(t % 3), ds[l].w, ds[o].w);
        for (int c = 0; c < 3; ++c)
          v[((size_t(t) * n + o) * n + l) * 3 + c] = float(s * f[size_t(c)] * ds[l].w.z);
      }
  }
  return v;
}

CodecSettings neural(int steps) {
  CodecSettings s;
  s.codec = "neural";
  s.components = 4;
  s.neuralSteps = steps;
  s.trainTexels = 64;
  return s;
}

std::string rawOf(const std::string& name, const BtfInfo& info, const std::vector<float>& v) {
  return writeRaw((test::tempDir("neural") / name).string(), info, v);
}

}  // namespace

TEST(Neural, TexelsFromAFewAnalyticBrdfsReconstructWithinOnePercent) {
  const BtfInfo info = syntheticInfo(6, 6, "6x12");
  const std::string raw = rawOf("three.btf", info, analyticValues(info, false));
  CompressReport rep;
  const auto dec = makeDecoder(compressStore(raw, neural(4000), false, nullptr, &rep));
  const ErrorReport e = compareBtfs(*openBtf(raw), *dec, false);
  EXPECT_LT(e.relRmse, 0.01);
  // Per texel too, not only on the tile.
  double worst = 0;
  for (float x : e.texelRmse) worst = std::max(worst, double(x));
  EXPECT_LT(worst / e.refRms, 0.03);
}

TEST(Neural, OneAnalyticBrdfDecodedBetweenTheSetsDirectionsMatchesTheClosedForm) {
  const BtfInfo info = syntheticInfo(3, 3, "6x12");
  const std::string raw = rawOf("one.btf", info, analyticValues(info, true));
  const auto dec = makeDecoder(compressStore(raw, neural(1500), false, nullptr, nullptr));
  ASSERT_TRUE(dec->continuous());
  // Directions half way between the set's (θ steps of 15°, φ of 30°): midpoints in both.
  double err = 0, ref = 0;
  int count = 0;
  for (double ti = 7.5; ti < 80; ti += 15)
    for (double pi = 15; pi < 360; pi += 60)
      for (double to = 7.5; to < 80; to += 15)
        for (double po = 45; po < 360; po += 60) {
          const double r = M_PI / 180;
          const DVec3 wi = sphericalDir(ti * r, pi * r), wo = sphericalDir(to * r, po * r);
          const auto f = analytic(1, wi, wo);
          const auto v = dec->evaluate(4, ti * r, pi * r, to * r, po * r);
          for (int c = 0; c < 3; ++c) {
            ASSERT_TRUE(std::isfinite(v[size_t(c)]) && v[size_t(c)] >= 0);
            const double a = f[size_t(c)] * wi.z;
            err += (v[size_t(c)] - a) * (v[size_t(c)] - a);
            ref += a * a;
          }
          ++count;
        }
  EXPECT_EQ(count, 900);
  EXPECT_LT(std::sqrt(err / ref), 0.02);
  // At a set direction the continuous decode is the set's value.
  const DirectionSet ds = DirectionSet::fromName("6x12");
  const auto a = dec->value(4, 10, 30);
  const auto b = dec->evaluate(4, ds[30].theta, ds[30].phi, ds[10].theta, ds[10].phi);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[size_t(c)], b[size_t(c)], 1e-5f);
}

// `compare` against a BTF at another direction set evaluates the file at the reference's
// directions: the neural file (trained at 6×12) within 2 % of the closed form at 5×10 — none of
// whose directions is one of 6×12's — and says so; the same values at the file's own set agree.
TEST(Neural, CompareAtAnotherDirectionSetEvaluatesTheFileThere) {
  const BtfInfo info = syntheticInfo(3, 3, "6x12"), other = syntheticInfo(3, 3, "5x10");
  const auto dir = test::tempDir("neural_sets");  // one folder: tempDir empties it
  const std::string raw = writeRaw((dir / "set.btf").string(), info, analyticValues(info, true));
  const std::string off =
      writeRaw((dir / "off.btf").string(), other, analyticValues(other, true));
  const std::string file = (dir / "set.cbtf").string();
  const CompressedBtf cb = compressStore(raw, neural(1500), false, nullptr, nullptr);
  writeCompressed(file, cb);
  std::string out;
  ASSERT_EQ(runBtfsim("compare " + off + " " + file + " --json -q", &out), 0) << out;
  const auto j = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(j.at("b_at_a_directions"), "continuous") << out;
  EXPECT_EQ(j.at("values").get<int64_t>(), int64_t(9) * 50 * 50 * 3) << out;
  EXPECT_LT(j.at("relative_rmse").get<double>(), 0.02) << out;
  ASSERT_EQ(runBtfsim("compare " + raw + " " + file + " --json -q", &out), 0) << out;
  EXPECT_FALSE(nlohmann::json::parse(out.substr(out.find('{'))).contains("b_at_a_directions"));
  // A raw store at another set is interpolated, and said to be.
  ASSERT_EQ(runBtfsim("compare " + off + " " + raw + " --json -q", &out), 0) << out;
  EXPECT_EQ(nlohmann::json::parse(out.substr(out.find('{'))).at("b_at_a_directions"),
            "interpolated");
  // The hemisphere slice of one texel and of the tile average is the network's own value at
  // each pixel's view (sin θ = r) and the light, not interpolated between the set's views.
  const auto dec = makeDecoder(cb);
  for (const std::string texel : {"1,1", "avg"}) {
    SCOPED_TRACE(texel);
    const std::string img = (dir / "h.exr").string();
    ASSERT_EQ(runBtfsim("slice " + file + " --texel " + texel + " --light 20,40 --size 24 -q -o " +
                            img,
                        &out),
              0)
        << out;
    int w = 0, h = 0;
    const auto px = readRgbImage(img, &w, &h);
    ASSERT_EQ(w, 24);
    ASSERT_EQ(h, 24);
    int inside = 0;
    for (int row = 0; row < h; ++row)
      for (int i = 0; i < w; ++i) {
        const int jj = h - 1 - row;  // rows top first, +y up
        const double x = (i + 0.5) / w * 2 - 1, y = (jj + 0.5) / h * 2 - 1;
        const double rr = std::hypot(x, y);
        const float* p = &px[(size_t(row) * w + size_t(i)) * 3];
        if (rr > 1) {
          EXPECT_EQ(p[0], 0.0f);
          continue;
        }
        ++inside;
        double want[3] = {0, 0, 0};
        const int64_t t0 = texel == "avg" ? 0 : 4, t1 = texel == "avg" ? 9 : 5;
        for (int64_t t = t0; t < t1; ++t) {
          const auto v = dec->evaluate(t, 20 * M_PI / 180, 40 * M_PI / 180, std::asin(rr),
                                       std::atan2(y, x));
          for (int c = 0; c < 3; ++c) want[c] += v[size_t(c)] / double(t1 - t0);
        }
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(p[c], want[c], 1e-5 * want[c] + 1e-7);
      }
    EXPECT_GT(inside, 400);
  }
  // Other texel grids are still refused.
  const BtfInfo grid = syntheticInfo(2, 3, "5x10");
  const std::string small =
      writeRaw((dir / "small.btf").string(), grid, analyticValues(grid, true));
  EXPECT_NE(runBtfsim("compare " + small + " " + file + " -q", &out), 0);
  EXPECT_NE(out.find("texel grids differ"), std::string::npos) << out;
}

// A training run killed (SIGKILL: no handler runs) leaves no file that could pass for a finished
// one, and the same command run again writes a whole, readable file.
TEST(Neural, AKilledTrainingLeavesNoFileAndARerunFinishes) {
  const BtfInfo info = syntheticInfo(4, 4, "4x8");
  const auto dir = test::tempDir("neural_kill");
  const std::string raw = writeRaw((dir / "a.btf").string(), info, analyticValues(info, false));
  const std::string file = (dir / "a.cbtf").string();
  std::string out;
  EXPECT_EQ(runBtfsim("compress " + raw + " -o " + file + " --codec neural --neural-steps 1000000",
                      &out, "timeout -s KILL 2"),
            137)
      << out;
  EXPECT_FALSE(std::filesystem::exists(file));
  ASSERT_EQ(runBtfsim("compress " + raw + " -o " + file + " --codec neural --neural-steps 100 -q",
                      &out),
            0)
      << out;
  EXPECT_FALSE(std::filesystem::exists(file + ".partial"));
  EXPECT_EQ(makeDecoder(readCompressed(file))->kind(), "neural");
}

TEST(Neural, SameRequestWritesTheSameBytesWithAnyThreadCount) {
  const BtfInfo info = syntheticInfo(5, 4, "4x8");
  const std::string raw = rawOf("threads.btf", info, analyticValues(info, false));
  CompressedBtf one, many;
  tbb::task_arena(1).execute([&] { one = compressStore(raw, neural(60), false, nullptr, nullptr); });
  tbb::task_arena(4).execute([&] { many = compressStore(raw, neural(60), false, nullptr, nullptr); });
  ASSERT_EQ(one.arrays.size(), 3u);
  ASSERT_EQ(one.arrays.size(), many.arrays.size());
  for (size_t i = 0; i < one.arrays.size(); ++i)
    EXPECT_TRUE(one.arrays[i].data == many.arrays[i].data) << one.arrays[i].name;
  CodecSettings other = neural(60);
  other.seed = 2;
  const CompressedBtf reseeded = compressStore(raw, other, false, nullptr, nullptr);
  EXPECT_FALSE(reseeded.array("neural.weights").data == one.array("neural.weights").data);
}

TEST(Neural, DamagedTablesAreRefusedNamingTheField) {
  const BtfInfo info = syntheticInfo(4, 3, "4x8");
  const std::string raw = rawOf("damaged.btf", info, analyticValues(info, false));
  const CompressedBtf good = compressStore(raw, neural(20), false, nullptr, nullptr);
  auto refused = [&](const std::function<void(CompressedBtf&)>& damage, const std::string& what) {
    CompressedBtf c = good;
    damage(c);
    try {
      makeDecoder(std::move(c));
      ADD_FAILURE() << "accepted: " << what;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  auto arrayOf = [](CompressedBtf& c, const std::string& name) -> CArray& {
    for (CArray& a : c.arrays)
      if (a.name == name) return a;
    throw Error("no " + name);
  };
  refused([&](CompressedBtf& c) { arrayOf(c, "neural.weights").data[7] = NAN; },
          "neural.weights holds a non-finite value");
  refused([&](CompressedBtf& c) { arrayOf(c, "neural.latents").data[3] = INFINITY; },
          "neural.latents holds a non-finite value");
  refused([&](CompressedBtf& c) { arrayOf(c, "neural.gain").data[2] = -1; }, "neural.gain");
  refused(
      [&](CompressedBtf& c) {
        CArray& w = arrayOf(c, "neural.weights");
        w.cols -= 1;
        w.data.pop_back();
      },
      "neural.weights is 1 × ");
  refused(
      [&](CompressedBtf& c) {
        CArray& z = arrayOf(c, "neural.latents");
        z.rows -= 1;
        z.data.resize(size_t(z.rows * z.cols));
      },
      "neural.latents is ");
  refused([&](CompressedBtf& c) { c.paramsJson = R"({"latent": 4})"; }, "params.hidden");
  refused([&](CompressedBtf& c) { c.paramsJson = R"({"latent": 900, "hidden": 32})"; },
          "params.latent = 900");
  // The good file decodes finite, non-negative values everywhere.
  const auto dec = makeDecoder(good);
  std::vector<float> buf(size_t(info.nDirs()) * info.nDirs() * 3);
  for (int64_t t = 0; t < info.texels(); ++t) {
    dec->texel(t, buf.data());
    for (float x : buf) ASSERT_TRUE(std::isfinite(x) && x >= 0);
  }
}

TEST(Neural, ACancelledTrainingThrowsAndAnAllZeroTexelDecodesToZero) {
  const BtfInfo info = syntheticInfo(4, 4, "4x8");
  std::vector<float> v = analyticValues(info, false);
  const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
  std::fill_n(v.begin() + ptrdiff_t(5 * stride), stride, 0.f);  // texel 5: fully shadowed
  const std::string raw = rawOf("zero.btf", info, v);
  CancelToken cancel;
  cancel.cancel();
  EXPECT_THROW(compressStore(raw, neural(50), false, &cancel, nullptr), Cancelled);
  const auto dec = makeDecoder(compressStore(raw, neural(50), false, nullptr, nullptr));
  std::vector<float> buf(stride);
  dec->texel(5, buf.data());
  for (float x : buf) EXPECT_EQ(x, 0.f);
  EXPECT_EQ(dec->evaluate(5, 0.3, 0.2, 0.4, 2.0)[0], 0.f);
}
