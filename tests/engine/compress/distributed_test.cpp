// What a cluster job relies on, without MPI (docs/cluster.md): encoders that each add a share of
// the texels and are merged (addedState / mergeAdded) write the arrays one encoder fed every
// texel writes, for every codec; corrupt states are refused; exact sums do not depend on the
// order; the Gram-matrix PCA the nmf codec reduces equals the sample PCA; the one-process
// communicator's collectives and agreements.
#include <btf/compress/compress.h>
#include <btf/core/comm.h>
#include <btf/core/error.h>
#include <btf/core/exact_sum.h>
#include <btf/core/rng.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "engine/compress/synthetic.h"
#include "test_util.h"

using namespace btf;
using namespace btf::test;

TEST(Distributed, EncodersMergedFromThreeRanksWriteTheSameArraysAsOne) {
  const BtfInfo info = syntheticInfo(7, 6, "4x8");
  const auto values = syntheticValues(info, {3, 4, 20}, 30.0);
  const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
  for (const std::string& codec : codecNames()) {
    CodecSettings s;
    s.codec = codec;
    s.trainTexels = 16;
    s.clusters = 3;
    s.targetRatio = 8;
    s.neuralSteps = 50;
    auto one = trainedEncoder(s, info, values);
    one->add(0, info.texels(), values.data());
    const CompressedBtf single = one->finish();
    // Three "ranks": chunk c of 5 texels goes to rank c mod 3; rank 0 merges 1 and 2.
    std::vector<std::unique_ptr<Encoder>> ranks;
    for (int q = 0; q < 3; ++q) ranks.push_back(trainedEncoder(s, info, values));
    for (int64_t t0 = 0, c = 0; t0 < info.texels(); t0 += 5, ++c) {
      const int64_t t1 = std::min<int64_t>(info.texels(), t0 + 5);
      ranks[size_t(c % 3)]->add(t0, t1, values.data() + size_t(t0) * stride);
    }
    for (int q = 1; q < 3; ++q) ranks[0]->mergeAdded(ranks[size_t(q)]->addedState());
    const CompressedBtf merged = ranks[0]->finish();
    ASSERT_EQ(single.arrays.size(), merged.arrays.size()) << codec;
    for (size_t i = 0; i < merged.arrays.size(); ++i)
      EXPECT_TRUE(single.arrays[i].data == merged.arrays[i].data)
          << codec << " " << merged.arrays[i].name;
    EXPECT_EQ(single.paramsJson, merged.paramsJson) << codec;
    EXPECT_EQ(single.statsJson, merged.statsJson) << codec;
    // A rank that never received its share: finish names the missing texel.
    auto partial = trainedEncoder(s, info, values);
    partial->add(0, 5, values.data());
    EXPECT_THROW(partial->finish(), Error) << codec;
  }
}

TEST(Distributed, CorruptEncoderStatesAreRefused) {
  const BtfInfo info = syntheticInfo(4, 4, "4x8");
  const auto values = syntheticValues(info, {});
  for (const std::string& codec : codecNames()) {
    CodecSettings s;
    s.codec = codec;
    s.trainTexels = 8;
    s.clusters = 2;
    s.neuralSteps = 50;
    auto a = trainedEncoder(s, info, values);
    a->add(0, 8, values.data());
    const std::string state = a->addedState();
    ASSERT_FALSE(state.empty()) << codec;
    auto b = trainedEncoder(s, info, values);
    // Truncated by one byte; a texel index out of range.
    const std::string cut(state.begin(), state.end() - 1);
    EXPECT_THROW(b->mergeAdded(cut), Error) << codec;
    std::string bad = state;
    const size_t at = codec == "nmf" ? 16 : 0;  // nmf states begin with two counters
    const int64_t huge = int64_t(1) << 40;
    std::memcpy(bad.data() + at, &huge, sizeof huge);
    try {
      b->mergeAdded(bad);
      ADD_FAILURE() << codec << ": an out-of-range texel was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("encoder state"), std::string::npos) << e.what();
    }
  }
}

TEST(Distributed, TheOneProcessCommunicator) {
  Comm& c = localComm();
  EXPECT_EQ(c.rank(), 0);
  EXPECT_EQ(c.size(), 1);
  EXPECT_FALSE(c.distributed());
  EXPECT_EQ(c.allgather("abc"), std::vector<std::string>{"abc"});
  EXPECT_EQ(sumInRankOrder(c, {1.5, -2}), (std::vector<double>{1.5, -2}));
  EXPECT_NO_THROW(requireSame(c, "the request", "x"));
  // One process: its own error, unchanged (not a CollectiveError).
  try {
    collectively(c, [] { throw Error("disk full"); });
    FAIL();
  } catch (const CollectiveError&) {
    FAIL() << "one process has nobody to agree with";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "disk full");
  }
  const std::vector<double> v = {0.25, 1e300, -0.0};
  EXPECT_EQ(unpackDoubles(packDoubles(v)), v);
  EXPECT_THROW(unpackDoubles("abc"), Error);
}

TEST(Distributed, ExactSumsAreTheSameBitsInAnyOrder) {
  // Terms spanning 12 decades with both signs: a double sum depends on the order, the exact one
  // does not, and stays within rounding of the true sum.
  std::vector<double> terms;
  for (int i = 0; i < 4000; ++i)
    terms.push_back((i % 2 ? -1 : 1) * std::pow(10.0, (i % 13) - 6) * (1 + 1e-3 * i));
  auto exact = [](const std::vector<double>& v) {
    Exact s = 0;
    for (double x : v) s += toExact(x);
    return fromExact(s);
  };
  auto plain = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return s;
  };
  std::vector<double> reversed(terms.rbegin(), terms.rend());
  EXPECT_EQ(exact(terms), exact(reversed));
  EXPECT_NE(plain(terms), plain(reversed));  // why the codecs do not use plain sums
  long double truth = 0;
  for (double x : terms) truth += x;
  EXPECT_NEAR(exact(terms), double(truth), 4000 / kExactScale + 1e-15 * std::abs(double(truth)));
}

TEST(Distributed, PcaFromTheGramMatrixMatchesPcaFromTheSamples) {
  Rng r(5);
  la::MatF X(12, 40);
  for (int64_t i = 0; i < X.size(); ++i) X.data()[i] = float(r.uniformDouble() - 0.3);
  const la::Basis a = la::pcaBasis(X, 6);
  const Eigen::MatrixXd Xd = X.cast<double>();
  const la::Basis b = la::pcaBasisFromGram(Xd * Xd.transpose(), 6);
  EXPECT_NEAR(a.total, b.total, 1e-9 * a.total);
  ASSERT_EQ(a.B.cols(), b.B.cols());
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(a.eigen[k], b.eigen[k], 1e-9 * a.eigen[0]);
    // The same direction (up to sign).
    EXPECT_NEAR(std::abs(a.B.col(k).dot(b.B.col(k))), 1.0f, 1e-4f) << k;
  }
}
