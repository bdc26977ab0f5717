// The tensor codec's algebra and codec on constructed data: sketch folding, IRP k-means on
// planted clusters, HOOI's monotone error, and a BTF built from known per-cluster low-rank
// tensors reconstructed exactly with its ranks and clusters recovered.
#include <btf/compress/compress.h>
#include <btf/compress/tensor.h>
#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "engine/compress/synthetic.h"
#include "test_util.h"

using namespace btf;
using namespace btf::test;

namespace {

float gauss(Rng& r) {
  // Box–Muller from two uniforms in (0, 1].
  const double u = 1.0 - r.uniformDouble(), v = r.uniformDouble();
  return float(std::sqrt(-2 * std::log(u)) * std::cos(2 * M_PI * v));
}

la::MatF randomMat(Rng& r, int rows, int cols) {
  la::MatF M(rows, cols);
  for (int64_t i = 0; i < M.size(); ++i) M.data()[i] = gauss(r);
  return M;
}

la::MatF orthonormal(Rng& r, int rows, int cols) {
  Eigen::HouseholderQR<la::MatF> qr(randomMat(r, rows, cols));
  return qr.householderQ() * la::MatF::Identity(rows, cols);
}

}  // namespace

TEST(Tensor, FoldingASketchIsTheSmallerSketchOfTheSameInput) {
  Rng r(3);
  std::vector<float> x(5000);
  for (float& v : x) v = gauss(r);
  const la::SignSketch big(5000, 64, 11), small(5000, 8, 11);
  la::MatF a(64, 1);
  std::vector<float> b(8);
  big.apply(x.data(), a.data());
  small.apply(x.data(), b.data());
  const la::MatF f = la::foldSketch(a, 8);
  for (int j = 0; j < 8; ++j)
    EXPECT_NEAR(f(j, 0), b[size_t(j)], 1e-4f * (1 + std::abs(b[size_t(j)])));
  // A sketch preserves squared norms on average: within a factor for one vector at D = 64.
  double n2 = 0, s2 = 0;
  for (float v : x) n2 += double(v) * v;
  for (int j = 0; j < 64; ++j) s2 += double(a(j, 0)) * a(j, 0);
  EXPECT_GT(s2, 0.5 * n2);
  EXPECT_LT(s2, 1.5 * n2);
  EXPECT_THROW(la::SignSketch(10, 48, 1), Error);  // not a power of two
}

TEST(Tensor, IrpKMeansRecoversPlantedClusters) {
  Rng r(7);
  const int dim = 4000, K = 5, per = 40;
  std::vector<std::vector<float>> centres(K, std::vector<float>(dim));
  for (auto& c : centres)
    for (float& v : c) v = gauss(r);
  const la::SignSketch sk(dim, 64, 5);
  la::MatF X(64, K * per);
  std::vector<int> truth;
  std::vector<float> p(dim);
  for (int i = 0; i < K * per; ++i) {
    const int k = (i * 7) % K;  // interleaved: the order carries no hint
    for (int d = 0; d < dim; ++d) p[size_t(d)] = centres[size_t(k)][size_t(d)] + 0.3f * gauss(r);
    sk.apply(p.data(), X.col(i).data());
    truth.push_back(k);
  }
  const la::KMeansResult km = la::irpKMeans(X, K, 1);
  ASSERT_EQ(km.assign.size(), size_t(K * per));
  EXPECT_EQ(km.dims, (std::vector<int>{2, 4, 8, 16, 32, 64}));
  // Every found cluster holds one planted cluster, whole.
  std::map<int, std::set<int>> found;
  for (int i = 0; i < K * per; ++i) found[km.assign[size_t(i)]].insert(truth[size_t(i)]);
  ASSERT_EQ(found.size(), size_t(K));
  for (const auto& [k, labels] : found) EXPECT_EQ(labels.size(), 1u) << "cluster " << k;
  // Deterministic.
  EXPECT_EQ(la::irpKMeans(X, K, 1).assign, km.assign);
}

TEST(Tensor, HooiNeverIncreasesTheErrorAndReportsItExactly) {
  Rng r(21);
  const int m = 30, nV = 12, nL = 10;
  std::vector<la::MatF> A;
  for (int i = 0; i < m; ++i) A.push_back(randomMat(r, nV, nL));
  std::vector<const la::MatF*> p;
  for (const auto& a : A) p.push_back(&a);
  std::vector<double> errors;
  const la::Tucker3 t = la::hooi(p, 3, 4, 5, 8, &errors);
  ASSERT_EQ(errors.size(), 9u);
  for (size_t s = 1; s < errors.size(); ++s)
    EXPECT_LE(errors[s], errors[s - 1] * (1 + 1e-6)) << "sweep " << s;
  EXPECT_LT(errors.back(), errors.front());  // HOOI improves on HOSVD for a random tensor
  // The reported error is the reconstruction's: Â_i = Uv (Σ_c Ut(i, c) core_c) Ulᵀ.
  double err = 0;
  for (int i = 0; i < m; ++i) {
    la::MatF M = la::MatF::Zero(3, 4);
    for (int c = 0; c < 5; ++c) M += t.Ut(i, c) * t.coreSlices[size_t(c)];
    err += (A[size_t(i)] - t.Uv * M * t.Ul.transpose()).cast<double>().squaredNorm();
  }
  EXPECT_NEAR(err, t.error, 1e-4 * t.energy);
  // Orthonormal factors.
  EXPECT_LT((t.Uv.transpose() * t.Uv - la::MatF::Identity(3, 3)).norm(), 1e-4);
  EXPECT_LT((t.Ut.transpose() * t.Ut - la::MatF::Identity(5, 5)).norm(), 1e-4);
}

TEST(Tensor, HosvdSpectraBoundTheTruncationError) {
  Rng r(5);
  std::vector<la::MatF> A;
  for (int i = 0; i < 20; ++i) A.push_back(randomMat(r, 8, 9));
  std::vector<const la::MatF*> p;
  for (const auto& a : A) p.push_back(&a);
  const la::ModeSpectra s = la::modeSpectra(p);
  EXPECT_NEAR(s.view.sum(), s.energy, 1e-6 * s.energy);
  EXPECT_NEAR(s.light.sum(), s.energy, 1e-6 * s.energy);
  EXPECT_NEAR(s.texel.sum(), s.energy, 1e-6 * s.energy);
  const la::Tucker3 t = la::hooi(p, 4, 5, 6, 0);
  const double bound =
      s.view.tail(8 - 4).sum() + s.light.tail(9 - 5).sum() + s.texel.tail(20 - 6).sum();
  EXPECT_LE(t.error, bound * (1 + 1e-6));
}

TEST(Tensor, PlantedLowRankClustersAreRecoveredExactly) {
  // Two clusters of texels (checkerboard columns), each the tensor of its own view and light
  // bases with multilinear ranks (2, 3, 2) and (3, 2, 2); channels scaled copies.
  const BtfInfo info = syntheticInfo(8, 6, "4x8");
  const int n = info.nDirs();
  Rng r(99);
  struct Planted {
    la::MatF Uv, Ul;
    std::vector<la::MatF> core;  // Rt slices Rv × Rl
    int rv, rl, rt;
  } pl[2];
  const int ranks[2][3] = {{2, 3, 2}, {3, 2, 2}};  // each ≤ the product of the two others
  for (int k = 0; k < 2; ++k) {
    pl[k].rv = ranks[k][0], pl[k].rl = ranks[k][1], pl[k].rt = ranks[k][2];
    pl[k].Uv = orthonormal(r, n, pl[k].rv);
    pl[k].Ul = orthonormal(r, n, pl[k].rl);
    for (int j = 0; j < pl[k].rt; ++j) pl[k].core.push_back(randomMat(r, pl[k].rv, pl[k].rl));
  }
  std::vector<float> v(size_t(info.texels()) * n * n * 3);
  std::vector<int> truth;
  for (int64_t t = 0; t < info.texels(); ++t) {
    const int k = int(t % info.nu) % 2;
    truth.push_back(k);
    la::MatF M = la::MatF::Zero(pl[k].rv, pl[k].rl);
    // Texels spread around their cluster's own mean: 4·core_0 + g·core_1.
    M += 4.f * pl[k].core[0] + gauss(r) * pl[k].core[1];
    const la::MatF A = pl[k].Uv * M * pl[k].Ul.transpose();
    for (int o = 0; o < n; ++o)
      for (int l = 0; l < n; ++l)
        for (int c = 0; c < 3; ++c)
          v[((size_t(t) * n + o) * n + l) * 3 + size_t(c)] = A(o, l) * (1.f - 0.3f * float(c));
  }
  const auto dir = tempDir("tensor_planted");
  const std::string raw = writeRaw((dir / "a.btf").string(), info, v);
  CodecSettings s;
  s.codec = "tensor";
  s.colour = "rgb";
  s.half = false;
  s.clusters = 2;
  s.targetRmse = 1e-3;  // above the float Gram matrices' rounding (~1e-7 of the energy)
  const CompressedBtf c = compressStore(raw, s, false, nullptr, nullptr);
  // Clusters: the planted partition (up to the labels' order).
  const CArray& cl = c.array("cluster");
  std::map<int, std::set<int>> found;
  for (int64_t t = 0; t < info.texels(); ++t)
    found[int(cl.data[size_t(t)])].insert(truth[size_t(t)]);
  ASSERT_EQ(found.size(), 2u);
  for (const auto& [k, labels] : found) ASSERT_EQ(labels.size(), 1u);
  // Ranks: exactly the planted ones, in every channel.
  for (int ch = 0; ch < 3; ++ch) {
    const CArray& rk = c.array(channelArray(ch, "ranks"));
    for (int k = 0; k < 2; ++k) {
      const int p = *found[k].begin();
      EXPECT_EQ(rk.at(k, 0), float(pl[p].rv)) << "channel " << ch << " cluster " << k;
      EXPECT_EQ(rk.at(k, 1), float(pl[p].rl)) << "channel " << ch << " cluster " << k;
      EXPECT_EQ(rk.at(k, 2), float(pl[p].rt)) << "channel " << ch << " cluster " << k;
    }
  }
  // Values: exact to float rounding (the data are signed here: compare the raw channels).
  const auto dec = makeDecoder(c);
  double e2 = 0, r2 = 0;
  std::vector<float> buf(size_t(n) * n * 3);
  for (int64_t t = 0; t < info.texels(); ++t) {
    dec->texel(t, buf.data());
    for (size_t i = 0; i < buf.size(); ++i) {
      const double ref = std::max(0.f, v[size_t(t) * buf.size() + i]);
      e2 += (buf[i] - ref) * (buf[i] - ref);
      r2 += ref * ref;
    }
    // Random access (the projected cores W = xᵀ core per cluster and view) = the whole texel.
    for (int q = 0; q < 16; ++q) {
      const int vv = int((t * 7 + q * 13) % n), ll = int((t * 11 + q * 5 + 3) % n);
      const auto one = dec->value(t, vv, ll);
      for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(one[size_t(ch)], buf[(size_t(vv) * n + size_t(ll)) * 3 + size_t(ch)],
                    1e-5f * (1 + std::abs(one[size_t(ch)])));
    }
  }
  EXPECT_LT(std::sqrt(e2 / r2), 1e-5);
}

TEST(Tensor, DamagedTablesAreRefusedWithTheirReason) {
  const BtfInfo info = syntheticInfo(5, 4, "4x8");
  const auto dir = tempDir("tensor_damaged");
  const std::string raw = writeRaw((dir / "a.btf").string(), info, syntheticValues(info, {}));
  CodecSettings s;
  s.codec = "tensor";
  s.clusters = 2;
  const CompressedBtf good = compressStore(raw, s, false, nullptr, nullptr);
  auto expectRefused = [&](const char* array, int64_t i, float value, const char* reason) {
    CompressedBtf c = good;
    for (CArray& a : c.arrays)
      if (a.name == array) a.data[size_t(i)] = value;
    try {
      makeDecoder(c);
      FAIL() << array << "[" << i << "] = " << value << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
    }
  };
  expectRefused("cluster", 3, 7.f, "names cluster 7");
  expectRefused("cluster", 3, std::nanf(""), "names cluster");
  expectRefused("c0.ranks", 0, 65.f, "invalid ranks");
  expectRefused("c1.ranks", 2, 0.5f, "invalid ranks");
  expectRefused("c0.ranks", 1, float(good.array("c0.ranks").at(0, 1) + 1), "its ranks need");
}

TEST(Tensor, AnAllZeroBtfCodesNothingAndDecodesZeros) {
  const BtfInfo info = syntheticInfo(4, 3, "4x8");
  const auto dir = tempDir("tensor_zero");
  const std::vector<float> zero(size_t(info.texels()) * info.nDirs() * info.nDirs() * 3, 0.f);
  const std::string raw = writeRaw((dir / "a.btf").string(), info, zero);
  for (const double ratio : {0.0, 300.0}) {
    CodecSettings s;
    s.codec = "tensor";
    s.targetRatio = ratio;
    const CompressedBtf c = compressStore(raw, s, false, nullptr, nullptr);
    EXPECT_EQ(c.array("coef").rows, 0);
    for (int ch = 0; ch < 3; ++ch) EXPECT_EQ(c.array(channelArray(ch, "core")).rows, 0);
    const auto dec = makeDecoder(c);
    std::vector<float> buf(size_t(info.nDirs()) * info.nDirs() * 3, 1.f);
    for (int64_t t = 0; t < info.texels(); ++t) {
      dec->texel(t, buf.data());
      for (float x : buf) ASSERT_EQ(x, 0.f);
      const auto v = dec->value(t, 3, 7);
      for (float x : v) ASSERT_EQ(x, 0.f);
    }
  }
}

TEST(Tensor, ARatioItsCapsCannotSpendIsReportedWithTheLimits) {
  // 6 × 4 texels of 32 directions, uniform noise (full rank): at 1:1.1 the ranks reach
  // their caps (every mode full) long before the raw bytes are spent; at 1:20 the bytes are
  // spent.
  const BtfInfo info = syntheticInfo(6, 4, "4x8");
  const auto dir = tempDir("tensor_ratio_limit");
  Rng rng(5);
  std::vector<float> noise(size_t(info.texels()) * info.nDirs() * info.nDirs() * 3);
  for (float& x : noise) x = float(rng.uniformDouble());
  const std::string raw = writeRaw((dir / "a.btf").string(), info, noise);
  CodecSettings s;
  s.codec = "tensor";
  s.targetRatio = 1.1;
  const CompressedBtf loose = compressStore(raw, s, false, nullptr, nullptr);
  const auto st = nlohmann::json::parse(loose.statsJson);
  ASSERT_TRUE(st.contains("ratio_limit")) << loose.statsJson;
  EXPECT_GT(loose.ratio(), 1.1 * 1.1);
  const std::string why = st["ratio_limit"];
  EXPECT_NE(why.find("texel ranks at their cap"), std::string::npos) << why;
  EXPECT_NE(why.find("--clusters"), std::string::npos) << why;
  s.targetRatio = 20;
  const CompressedBtf tight = compressStore(raw, s, false, nullptr, nullptr);
  EXPECT_FALSE(nlohmann::json::parse(tight.statsJson).contains("ratio_limit")) << tight.statsJson;
  // At least the ratio asked (the header's reserve makes a tile this small land above it).
  EXPECT_GE(tight.ratio(), 20);
  EXPECT_LT(tight.ratio(), 30);
}
