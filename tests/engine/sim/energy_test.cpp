// No energy from nowhere: white scenes (albedo 1) keep a directional albedo ≤ 1 (plus the
// discretisation's tolerance) at every light of a 16×24 grid, grazing ones included, in every
// shadow mode — V-grooves with 80° walls, a box cavity and packed spheres.
#include <btf/sim/brdf_probe.h>
#include <btf/sim/path_tracer.h>
#include <btf/sim/simulator.h>
#include <gtest/gtest.h>

#include <cmath>

#include "test_util.h"

namespace btf {
namespace {

std::string whiteScene(const std::string& parts) {
  return R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": 1}}, "parts": [)" +
         parts + "]}";
}

const char* kGrooves80 =  // 4 grooves: half-width 0.125, depth 0.125·tan 80°
    R"({"type": "vgrooves", "material": "m", "count": 4, "depth": 0.7089})";
const char* kCavity = R"({"type": "plane", "material": "m"},
  {"type": "box", "material": "m", "center": [0.5, 0.05, 0.25], "size": [1.0, 0.1, 0.5]},
  {"type": "box", "material": "m", "center": [0.05, 0.5, 0.25], "size": [0.1, 1.0, 0.5]})";
const char* kPacked = R"({"type": "plane", "material": "m"},
  {"type": "sphere", "material": "m", "center": [0.5, 0.5, 0.25], "radius": 0.25, "segments": 48})";

// The light and view grid: 16 rings of 24, the outermost at 87.2° as with 16×32, which gave the
// same maxima within 0.3 % (V-grooves P = 3: 0.9878 both) at 1.4 times the time. 16×16 is
// faster still but moves the cavity's map+rays difference to 6.1 % (5.1 % at 16×32, 5.5 %
// here): the walls' alignment with the azimuths matters, so 24 per ring it is.
constexpr int kRings = 16, kPerRing = 24;
const char* kGrid = "16x24";

// Directional albedo Σ_v aBRDF(v, l) cos θv Ω_v of the tile average, for every light.
std::vector<double> albedos(const Scene& s, ShadowMode mode, int bounces, double grazingRays) {
  SimOptions o;
  o.nu = o.nv = 4;
  o.spp = 4;
  o.directions = kGrid;
  o.shadows = mode;
  o.grazingRays = grazingRays;
  o.progress = false;
  o.plan.interreflection = bounces > 1 ? Toggle::On : Toggle::Off;
  o.plan.bounces = bounces > 1 ? bounces : 0;
  SimulationJob job(s, o);
  const DirectionSet& d = job.directions();
  const int n = d.size();
  std::vector<double> a(size_t(n), 0.0);
  job.setChunkSink([&](int, int64_t t0, int64_t t1, const float* v) {
    for (int64_t t = t0; t < t1; ++t)
      for (int view = 0; view < n; ++view)
        for (int l = 0; l < n; ++l)
          a[size_t(l)] += double(v[((size_t(t - t0) * n + size_t(view)) * n + size_t(l)) * 3]) *
                          d[view].w.z * d[view].solidAngle / double(o.nu * o.nv);
  });
  job.run("", job.estimate(""));
  return a;
}

// One white scene in every shadow mode, P = 1 and 3. The exact-rays albedos are simulated once
// per path length and serve both as a case of their own and as the map mode's reference.
void expectEnergyBounded(const char* name, const std::string& json) {
  const Scene s = test::sceneFromJson(json);
  const DirectionSet d = DirectionSet::fromName(kGrid);
  for (int bounces : {1, 3}) {
    const auto exact = albedos(s, ShadowMode::Rays, bounces, 90);
    for (const auto& [mode, grazing] :
         {std::pair{ShadowMode::Map, 70.0}, std::pair{ShadowMode::Map, 90.0},
          std::pair{ShadowMode::Rays, 90.0}}) {
      const std::string label = std::string(shadowModeName(mode)) +
                                (mode == ShadowMode::Map && grazing < 90 ? "+rays" : "");
      SCOPED_TRACE(std::string(name) + ", " + label + ", P = " + std::to_string(bounces));
      const auto a = mode == ShadowMode::Rays ? exact : albedos(s, mode, bounces, grazing);
      double worst = 0;
      int worstL = 0;
      for (int l = 0; l < d.size(); ++l)
        if (a[size_t(l)] > worst) worst = a[size_t(l)], worstL = l;
      std::printf("  %-15s %-8s P=%d: max albedo %.4f at θi %.1f° φi %.1f°\n", name,
                  label.c_str(), bounces, worst, rad2deg(d[worstL].theta),
                  rad2deg(d[worstL].phi));
      if (std::getenv("BTF_ENERGY_RINGS")) {
        for (int ring = 0; ring < kRings; ++ring) {
          double m = 0;
          for (int k = 0; k < kPerRing; ++k) m = std::max(m, a[size_t(ring * kPerRing + k)]);
          std::printf("    θi %5.1f°: %.4f\n", rad2deg(d[ring * kPerRing].theta), m);
        }
      }
      EXPECT_LE(worst, 1.03);
      if (mode == ShadowMode::Map && grazing < 90) {
        // The default map mode stays with the exact rays, light by light.
        double dev = 0;
        size_t at = 0;
        for (size_t l = 0; l < a.size(); ++l)
          if (exact[l] > 0.05 && std::abs(a[l] - exact[l]) / exact[l] > dev)
            dev = std::abs(a[l] - exact[l]) / exact[l], at = l;
        std::printf(
            "  %-15s map+rays vs rays P=%d: largest relative difference %.2f %% (θi "
            "%.1f°)\n",
            name, bounces, 100 * dev, rad2deg(d[int(at)].theta));
        // Measured (16×24) 1.1–1.5 % on grooves and spheres, 3.3 % (direct) and 5.5 % (P = 3)
        // on the 0.1-thick walls of the cavity: thin walls span 1–2 map samples
        // (docs/conventions.md).
        EXPECT_LE(dev, 0.06);
      }
    }
  }
}

// One test per scene, so that ctest runs them side by side.
TEST(Energy, WhiteVGroovesNeverReflectMoreThanTheyReceive) {
  expectEnergyBounded("v-grooves 80°", whiteScene(kGrooves80));
}
TEST(Energy, WhiteBoxCavityNeverReflectsMoreThanItReceives) {
  expectEnergyBounded("box cavity", whiteScene(kCavity));
}
TEST(Energy, WhitePackedSpheresNeverReflectMoreThanTheyReceive) {
  expectEnergyBounded("packed spheres", whiteScene(kPacked));
}

}  // namespace
}  // namespace btf

namespace btf {
namespace {

// Grazing probes: bounded time and the right value up to the stated limit, a clear refusal past
// it (a wrong number is never returned).
TEST(Grazing, ProbesStayRightUpToTheLimitAndRefuseBeyond) {
  const Scene flat = test::sceneFromJson(
      R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": 0.5}},
          "parts": [{"type": "plane", "material": "m"}]})");
  SimOptions o;
  o.progress = false;
  SimulationJob job(flat, o);
  for (double t : {80.0, 89.0, 89.9, kMaxProbeThetaDeg}) {
    SCOPED_TRACE(t);
    const auto pairs =
        std::vector<DirectionPair>{pairFromDegrees(t, 0, t, 180), pairFromDegrees(t, 30, 10, 100)};
    const auto direct = averagedBrdf(job.tracer(), job.materials(), pairs, 8, 1);
    PathSettings ps;
    const auto pt = pathTracedBrdf(job.tracer(), job.materials(), pairs, 8, 1, ps);
    for (size_t k = 0; k < pairs.size(); ++k) {
      EXPECT_NEAR(direct[k].x, 0.5 / kPi, 1e-4);
      EXPECT_NEAR(pt[k].x, 0.5 / kPi, 1e-4);
    }
  }
  // Relief: the grazing limit is approached continuously (brick, path traced).
  const Scene brick = loadScene(test::sourceDir() + "/resources/scenes/brick.json");
  SimulationJob bj(brick, o);
  PathSettings ps;
  const auto near =
      pathTracedBrdf(bj.tracer(), bj.materials(), {pairFromDegrees(89.9, 0, 89.9, 180)}, 32, 1, ps);
  const auto limit =
      pathTracedBrdf(bj.tracer(), bj.materials(),
                     {pairFromDegrees(kMaxProbeThetaDeg, 0, kMaxProbeThetaDeg, 180)}, 32, 1, ps);
  EXPECT_NEAR(limit[0].x, near[0].x, 0.05 * near[0].x);
  for (double t : {89.995, 90.0, 95.0}) {
    try {
      pairFromDegrees(t, 0, 0, 0);
      ADD_FAILURE() << t << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("θ must be in [0, 89.99] degrees"), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace btf
