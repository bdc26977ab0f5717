// The path-traced reference: analytic flat tiles, the direct-only path equals the direct
// simulator, energy conservation of the tile albedo (monotone in the path length, ≤ 1, → 1 for
// albedo 1 when nothing absorbs), hard cases without NaN/Inf.
#include <btf/core/rng.h>
#include <btf/geometry/tile_builder.h>
#include <btf/sim/brdf_probe.h>
#include <btf/sim/direct.h>
#include <btf/sim/path_tracer.h>
#include <btf/sim/simulator.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace btf {
namespace {

std::string scene(const std::string& material, const std::string& parts) {
  return R"({"btfscene": 1, "materials": {"m": )" + material + R"(}, "parts": )" + parts + "}";
}
const char* kFlat = R"([{"type": "plane", "material": "m"}])";

struct Fixture {
  Scene s;
  TileGeometry g;
  std::unique_ptr<PeriodicTracer> tracer;
  std::vector<Material> mats;
  explicit Fixture(const std::string& json, bool addDegenerate = false)
      : s(test::sceneFromJson(json)) {
    g = buildTileGeometry(s);
    if (addDegenerate) test::addDegenerateTriangles(g);
    tracer = std::make_unique<PeriodicTracer>(g);
    mats = compileMaterials(s);
  }
};

TEST(PathTracer, FlatLambertIsExactAtAnyDepth) {
  Fixture f(scene(R"({"type": "lambert", "albedo": [0.8, 0.4, 0.2]})", kFlat));
  std::vector<DirectionPair> pairs = {pairFromDegrees(0, 0, 0, 0), pairFromDegrees(45, 30, 60, 200),
                                      pairFromDegrees(89.9, 0, 10, 90),
                                      pairFromDegrees(30, 0, 89.9, 180)};
  for (int P : {1, 3, 0}) {
    PathSettings ps;
    ps.maxBounces = P;
    const auto v = pathTracedBrdf(*f.tracer, f.mats, pairs, 8, 2, ps);
    for (const Rgb& c : v) {
      EXPECT_NEAR(c.x, 0.8 / kPi, 1e-5);
      EXPECT_NEAR(c.y, 0.4 / kPi, 1e-5);
      EXPECT_NEAR(c.z, 0.2 / kPi, 1e-5);
    }
  }
}

TEST(PathTracer, FlatCookTorranceMatchesItsBrdf) {
  Fixture f(scene(R"({"type": "cook_torrance", "diffuse": [0.1, 0.2, 0.3], "specular": 0.9,
                      "roughness": 0.2, "fresnel": "conductor"})",
                  kFlat));
  for (auto pr : {pairFromDegrees(30, 0, 30, 180), pairFromDegrees(60, 10, 20, 100),
                  pairFromDegrees(80, 0, 80, 180)}) {
    PathSettings ps;
    const Rgb v = pathTracedBrdf(*f.tracer, f.mats, {pr}, 4, 4, ps)[0];
    const Rgb ref = evalBrdf(f.mats[0], Vec3(pr.wi), Vec3(pr.wo));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(v[c], ref[c], 1e-5 * ref[c] + 1e-7);
  }
}

TEST(PathTracer, DirectOnlyPathEqualsTheDirectSimulator) {
  const Scene s =
      test::sceneFromJson(test::readFile(test::sourceDir() + "/resources/scenes/brick.json"),
                          test::sourceDir() + "/resources/scenes");
  SimOptions o;
  o.nu = o.nv = 8;
  o.spp = 2;
  o.directions = "bonn81";
  o.shadows = ShadowMode::Rays;
  SimulationJob job(s, o);
  SampleGrid grid{8, 8, 2, s.Lx, s.Ly, 1};
  HitMaps maps;
  maps.build(job.tracer(), job.directions(), grid);
  DirectIllumination d(job.tracer(), job.materials(), job.directions(), maps, {ShadowMode::Rays});
  const int n = job.directions().size();
  std::vector<DVec3> lights;
  for (const auto& dir : job.directions().dirs()) lights.push_back(DVec3(Vec3(dir.w)));
  PathSettings ps;
  ps.maxBounces = 1;
  std::vector<float> row(size_t(n) * 3);
  int bad = 0, nonzero = 0;
  for (int view : {0, 17, 40, 80}) {
    const auto pt = pathTracedTexels(job.tracer(), job.materials(), grid, job.directions()[view].w,
                                     lights, 1, ps);
    for (int t = 0; t < 64; ++t) {
      d.evalTexelView(t % 8, t / 8, view, row.data());
      for (int l = 0; l < n; ++l)
        for (int c = 0; c < 3; ++c) {
          const float a = row[size_t(l) * 3 + c], b = pt[size_t(t) * n + l][c];
          nonzero += a > 0;
          bad += std::abs(a - b) > 1e-5f * std::abs(a) + 1e-7f;
        }
    }
  }
  EXPECT_EQ(bad, 0);
  EXPECT_GT(nonzero, 1000);
}

// Tile albedo under light wi: ∫ aBRDF(wi, wo) cos θo dωo = π·E[aBRDF] with cosine-distributed wo.
double tileAlbedo(const Fixture& f, const DVec3& wi, int P, int samples, uint64_t seed = 3) {
  PathSettings ps;
  ps.maxBounces = P;
  ps.seed = seed;
  std::vector<Rgb> part(64, Rgb(0));
  parallelForChunks(64, 1, [&](int64_t b, int64_t e) {
    for (int64_t k = b; k < e; ++k) {
      Rng rng(hashKeys(seed, uint64_t(k)));
      for (int q = 0; q < samples / 64; ++q) {
        const float r = std::sqrt(rng.uniform()), phi = 2 * kPiF * rng.uniform();
        const DVec3 wo(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.f, 1 - r * r)));
        if (wo.z < 1e-4) continue;
        const DVec3 p0(rng.uniform() * f.g.Lx, rng.uniform() * f.g.Ly, 0);
        tracePath(*f.tracer, f.mats, p0, glm::normalize(wo), &wi, 1, ps, rng, 1.0f, &part[k]);
      }
    }
  });
  Rgb sum(0);
  for (const Rgb& v : part) sum += v;
  // The aBRDF divides by cos θi; the albedo is relative to the irradiance E⊥ cos θi.
  return double(sum.x) / double(samples / 64 * 64) * kPi;
}

const char* kVGroove = R"([{"type": "vgrooves", "material": "m", "count": 2, "depth": 0.5}])";
const char* kCavity = R"([{"type": "plane", "material": "m"},
  {"type": "box", "material": "m", "center": [0.5, 0.05, 0.25], "size": [1.0, 0.1, 0.5]},
  {"type": "box", "material": "m", "center": [0.05, 0.5, 0.25], "size": [0.1, 1.0, 0.5]}])";

TEST(PathTracer, EnergyGrowsWithPathLengthAndIsConserved) {
  for (const char* parts : {kVGroove, kCavity})
    for (double rho : {0.5, 1.0}) {
      SCOPED_TRACE(std::string(parts).substr(0, 30) + " ρ=" + std::to_string(rho));
      const std::string a = std::to_string(rho);
      Fixture f(scene(R"({"type": "lambert", "albedo": [)" + a + "," + a + "," + a + "]}", parts));
      const DVec3 wi = sphericalDir(deg2rad(40), deg2rad(20));
      double prev = 0;
      for (int P : {1, 2, 3, 5}) {
        const double e = tileAlbedo(f, wi, P, 64 * 1500);
        EXPECT_GT(e, prev) << "P=" << P;
        EXPECT_LE(e, 1.02) << "P=" << P;
        prev = e;
      }
      const double full = tileAlbedo(f, wi, 0, 64 * 3000);
      EXPECT_LE(full, 1.02);
      if (rho == 1.0)
        EXPECT_NEAR(full, 1.0, 0.03);  // nothing absorbs: everything comes out
      else
        EXPECT_LT(full, 0.97 * rho + 0.03);
    }
}

// The caller's sample weight (1 / samples in the BTF kernel) scales a path's contribution and
// nothing else: Russian roulette reads the throughput alone. (It once started the throughput at
// the weight, so a weight of 1/64 ended ~99 % of paths at the roulette depth and left the deeper
// orders to a few survivors scaled by ~64: unbiased, but per-texel noise of tens of per cent and
// tile averages several per cent off at V-grooves' deep pairs.)
TEST(PathTracer, SampleWeightOnlyScalesThePath) {
  Fixture f(scene(R"({"type": "lambert", "albedo": [0.8, 0.8, 0.8]})", kVGroove));
  const DirectionPair pr = pairFromDegrees(56.25, 22.5, 56.25, 247.5);
  const float w = 1.0f / 64;
  PathSettings unbounded, three;
  three.maxBounces = 3;
  int deeper = 0, mismatched = 0;
  for (int k = 0; k < 2000; ++k) {
    const DVec3 p0 = tilePosition(5, k % 50, k / 50, 50, f.g.Lx, f.g.Ly, 0);
    Rgb one(0), weighted(0), first3(0);
    Rng r1(hashKeys(9, uint64_t(k))), r2(hashKeys(9, uint64_t(k))), r3(hashKeys(9, uint64_t(k)));
    tracePath(*f.tracer, f.mats, p0, pr.wo, &pr.wi, 1, unbounded, r1, 1.0f, &one);
    tracePath(*f.tracer, f.mats, p0, pr.wo, &pr.wi, 1, unbounded, r2, w, &weighted);
    tracePath(*f.tracer, f.mats, p0, pr.wo, &pr.wi, 1, three, r3, 1.0f, &first3);
    deeper += one.x > first3.x * 1.001f;  // the path went past the roulette depth
    mismatched += std::abs(weighted.x - w * one.x) > 1e-5f * w * one.x + 1e-12f;
  }
  EXPECT_EQ(mismatched, 0);
  EXPECT_GT(deeper, 50);  // the comparison covers paths that met the roulette
}

// The BTF kernel's path tracer (one walk per sample shared by every light, weighted 1/samples)
// agrees with the tile-averaged path tracer at a pure-indirect V-groove pair, both ways round:
// the tile average is reciprocal.
TEST(PathTracer, TexelModeIsReciprocalAtADeepPair) {
  Fixture f(scene(R"({"type": "lambert", "albedo": [0.8, 0.8, 0.8]})", kVGroove));
  const DirectionPair a = pairFromDegrees(56.25, 22.5, 56.25, 247.5);
  const DirectionPair b = pairFromDegrees(56.25, 247.5, 56.25, 22.5);
  PathSettings ps;
  const auto ref = pathTracedBrdf(*f.tracer, f.mats, {a, b}, 128, 4, ps);
  const SampleGrid grid{16, 16, 4, f.g.Lx, f.g.Ly, 3};
  double avg[2] = {0, 0};
  int k = 0;
  for (const DirectionPair& pr : {a, b}) {
    const auto t = pathTracedTexels(*f.tracer, f.mats, grid, pr.wo, {pr.wi}, 16, ps);
    for (const Rgb& v : t) avg[k] += double(v.x) / double(t.size());
    ++k;
  }
  // Pure indirect light (the view sees only the unlit faces): 65 536 paths each, ~1 % noise.
  EXPECT_GT(ref[0].x, 0.09f);
  EXPECT_NEAR(ref[0].x, ref[1].x, 0.015 * ref[0].x);
  EXPECT_NEAR(avg[0], ref[0].x, 0.03 * ref[0].x);
  EXPECT_NEAR(avg[1], ref[1].x, 0.03 * ref[1].x);
  EXPECT_NEAR(avg[0], avg[1], 0.03 * (avg[0] + avg[1]) / 2);
}

TEST(PathTracer, HardCasesStayFinite) {
  // Near-mirror lobe, albedo 1 with unbounded paths, grazing directions, degenerate triangles.
  const char* mats[] = {
      R"({"type": "cook_torrance", "diffuse": [0, 0, 0], "specular": 1, "roughness": 0.01,
          "fresnel": "none"})",
      R"({"type": "lambert", "albedo": [1, 1, 1]})"};
  for (const char* m : mats) {
    Fixture f(scene(m, kCavity));
    std::vector<DirectionPair> pairs = {pairFromDegrees(89.9, 0, 89.9, 180),
                                        pairFromDegrees(89.9, 45, 0, 0),
                                        pairFromDegrees(30, 0, 30, 180)};
    const auto v = pathTracedBrdf(*f.tracer, f.mats, pairs, 24, 2, PathSettings{});
    for (const Rgb& c : v) {
      EXPECT_TRUE(finite3(c));
      EXPECT_GE(c.x, 0);
    }
  }
  Fixture deg(scene(R"({"type": "lambert", "albedo": [1, 1, 1]})", kCavity), true);
  const auto v = pathTracedBrdf(*deg.tracer, deg.mats,
                                {pairFromDegrees(60, 0, 70, 180), pairFromDegrees(0, 0, 0, 0)}, 32,
                                2, PathSettings{});
  EXPECT_TRUE(finite3(v[0]) && finite3(v[1]));
}

}  // namespace
}  // namespace btf
