// Codecs on constructed BTFs: exact reconstruction of low-rank data, identical results whether
// the texels arrive from a stored file or a stream in any chunking, file round trips and
// corruption errors, hard texels, and the decoder's direction interpolation.
#include <btf/compress/compress.h>
#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/directions/direction_set.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "engine/compress/synthetic.h"
#include "test_util.h"

using namespace btf;
using namespace btf::test;

namespace {

CodecSettings exact(const std::string& codec, const std::string& colour) {
  CodecSettings s;
  s.codec = codec;
  s.colour = colour;
  s.half = false;
  s.components = 6;
  s.beta = 0.999999;
  s.nmfIterations = 2000;
  s.nmfTolerance = 0;
  s.trainTexels = 40;
  s.clusters = 2;
  return s;
}

double relRmse(const Decoder& a, const Decoder& b) {
  return compareBtfs(a, b, false).relRmse;
}

}  // namespace

TEST(Codecs, LowRankBtfsReconstructToFloatPrecision) {
  const auto dir = test::tempDir("codec_exact");
  const BtfInfo info = syntheticInfo(6, 5, "4x8");
  const std::string raw = writeRaw((dir / "a.btf").string(), info, syntheticValues(info, {}));
  const auto ref = openBtf(raw);
  for (const std::string& codec : codecNames())
    for (const std::string colour : {"rgb", "ycc"}) {
      if (codec == "neural") continue;  // not a linear model: neural_test.cpp's own bounds
      CompressReport rep;
      CompressedBtf c = compressStore(raw, exact(codec, colour), false, nullptr, &rep);
      const auto dec = makeDecoder(std::move(c));
      const double e = relRmse(*ref, *dec);
      // NMF's rank-2 factors converge to ~1e-4; the linear codecs are exact to rounding.
      EXPECT_LT(e, codec == "nmf" ? 2e-3 : 2e-5) << codec << " " << colour;
    }
}

TEST(Codecs, StreamingInAnyChunkingEqualsCompressingTheStoredFile) {
  const auto dir = test::tempDir("codec_stream");
  const BtfInfo info = syntheticInfo(7, 6, "4x8");
  const auto values = syntheticValues(info, {3, 4, 20});
  const std::string raw = writeRaw((dir / "a.btf").string(), info, values);
  const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
  for (const std::string& codec : codecNames()) {
    CodecSettings s;
    s.codec = codec;
    s.trainTexels = 16;
    s.clusters = 3;
    s.components = 3;
    s.neuralSteps = 50;
    const CompressedBtf fromFile = compressStore(raw, s, false, nullptr, nullptr);
    // Stream: training texels first, then texels in reverse order in chunks of 5.
    auto enc = trainedEncoder(s, info, values);
    for (int64_t t1 = info.texels(); t1 > 0; t1 -= 5) {
      const int64_t t0 = std::max<int64_t>(0, t1 - 5);
      enc->add(t0, t1, values.data() + size_t(t0) * stride);
    }
    const CompressedBtf streamed = enc->finish();
    ASSERT_EQ(fromFile.arrays.size(), streamed.arrays.size());
    for (size_t i = 0; i < streamed.arrays.size(); ++i)
      EXPECT_TRUE(fromFile.arrays[i].data == streamed.arrays[i].data)
          << codec << " " << streamed.arrays[i].name;
  }
}

TEST(Codecs, FileRoundTripAndCorruptionErrors) {
  const auto dir = test::tempDir("codec_file");
  const BtfInfo info = syntheticInfo(5, 4, "bonn81");
  const std::string raw = writeRaw((dir / "a.btf").string(), info, syntheticValues(info, {}));
  CodecSettings s;
  s.codec = "nmf";
  const CompressedBtf c = compressStore(raw, s, false, nullptr, nullptr);
  const std::string path = (dir / "a.cbtf").string();
  writeCompressed(path, c);
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  EXPECT_EQ(std::filesystem::file_size(path), c.fileBytes());
  const CompressedBtf back = readCompressed(path);
  ASSERT_EQ(back.arrays.size(), c.arrays.size());
  for (size_t i = 0; i < c.arrays.size(); ++i) {
    EXPECT_EQ(back.arrays[i].name, c.arrays[i].name);
    EXPECT_TRUE(back.arrays[i].data == c.arrays[i].data) << c.arrays[i].name;
  }
  EXPECT_EQ(back.info.dirsDeg, info.dirsDeg);
  EXPECT_EQ(openBtf(path)->kind(), "nmf");
  // A flipped byte in the last array.
  const std::string bytes = test::readFile(path);
  {
    std::string bad = bytes;
    bad[bad.size() - 3] ^= 0x10;
    std::ofstream(dir / "flip.cbtf", std::ios::binary) << bad;
    try {
      readCompressed((dir / "flip.cbtf").string());
      FAIL() << "flipped byte accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("checksum mismatch in array"), std::string::npos)
          << e.what();
    }
  }
  {  // A flipped byte in the header.
    std::string bad = bytes;
    bad[40] ^= 0x01;
    std::ofstream(dir / "head.cbtf", std::ios::binary) << bad;
    EXPECT_THROW(readCompressed((dir / "head.cbtf").string()), Error);
  }
  {  // Truncated.
    std::ofstream(dir / "short.cbtf", std::ios::binary) << bytes.substr(0, bytes.size() - 100);
    try {
      readCompressed((dir / "short.cbtf").string());
      FAIL() << "truncated file accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
    }
  }
}

TEST(Codecs, ShadowedTexelsAndHugeDynamicRangeStayFinite) {
  const auto dir = test::tempDir("codec_hard");
  const BtfInfo info = syntheticInfo(6, 6, "4x8");
  // Texels 0, 5, 17 all zero (fully shadowed); the rest span 1e-6 … 1e3 of scale.
  const auto values = syntheticValues(info, {0, 5, 17}, 1e9);
  std::vector<float> scaled = values;
  for (float& x : scaled) x *= 1e-6f;
  const std::string raw = writeRaw((dir / "a.btf").string(), info, scaled);
  const auto ref = openBtf(raw);
  std::vector<float> buf(size_t(info.nDirs()) * info.nDirs() * 3);
  for (const std::string& codec : codecNames()) {
    CodecSettings s;
    s.codec = codec;
    s.trainTexels = 36;
    s.clusters = 4;
    s.neuralSteps = 1500;
    const auto dec = makeDecoder(compressStore(raw, s, false, nullptr, nullptr));
    for (int64_t t = 0; t < info.texels(); ++t) {
      dec->texel(t, buf.data());
      for (float x : buf) ASSERT_TRUE(std::isfinite(x) && x >= 0) << codec << " texel " << t;
      if (t == 0 || t == 5 || t == 17) {
        for (float x : buf) ASSERT_LT(x, 1e-2f) << codec << " shadowed texel " << t;
      }
    }
    const ErrorReport r = compareBtfs(*ref, *dec, false);
    EXPECT_TRUE(std::isfinite(r.relRmse));
    EXPECT_LT(r.relRmse, 0.05) << codec;  // the energy is in the bright texels: kept
  }
}

TEST(Codecs, DirectionInterpolationIsExactAtGridDirectionsAndContinuous) {
  const auto dir = test::tempDir("codec_interp");
  for (const std::string set : {"4x8", "bonn81"}) {
    const BtfInfo info = syntheticInfo(3, 2, set);
    const std::string raw =
        writeRaw((dir / (set + ".btf")).string(), info, syntheticValues(info, {}));
    const auto dec = makeDecoder(compressStore(raw, exact("svd", "rgb"), false, nullptr, nullptr));
    const DirectionSet ds = DirectionSet::fromName(set);
    for (int o = 0; o < ds.size(); o += 5)
      for (int l = 0; l < ds.size(); l += 3) {
        const auto v = dec->value(4, o, l);
        const auto e = dec->evaluate(4, ds[l].theta, ds[l].phi, ds[o].theta, ds[o].phi);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(e[size_t(c)], v[size_t(c)], 1e-6f * (1 + v[size_t(c)]));
      }
    // Continuity: small steps in θ and φ (across cell and ring boundaries) change little.
    double worst = 0;
    for (double th = 0.02; th < 1.5; th += 0.013)
      for (double ph = 0; ph < 6.28; ph += 0.37) {
        const auto a = dec->evaluate(1, 0.6, 1.0, th, ph);
        const auto b = dec->evaluate(1, 0.6, 1.0, th + 1e-4, ph + 1e-4);
        for (int c = 0; c < 3; ++c)
          worst = std::max(worst, double(std::abs(a[size_t(c)] - b[size_t(c)])));
      }
    EXPECT_LT(worst, 2e-3) << set;
  }
}

TEST(Codecs, BadSettingsAreClearErrors) {
  CodecSettings s;
  s.codec = "jpeg";
  try {
    validate(s);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown codec 'jpeg'"), std::string::npos);
  }
  s.codec = "nmf";
  s.targetRmse = 0.05;
  s.targetRatio = 300;
  EXPECT_THROW(validate(s), Error);
  s.targetRatio = 0;
  s.beta = 1.5;
  EXPECT_THROW(validate(s), Error);
}
