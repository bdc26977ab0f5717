// No energy from nowhere: white scenes (albedo 1) keep a directional albedo ≤ 1 (plus the
// discretisation's tolerance) at every light of a 16×32 grid, grazing ones included, in every
// shadow mode — V-grooves with 80° walls, a box cavity and packed spheres.
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

// Directional albedo Σ_v aBRDF(v, l) cos θv Ω_v of the tile average, for every light.
std::vector<double> albedos(const Scene& s, ShadowMode mode, int bounces) {
  SimOptions o;
  o.nu = o.nv = 4;
  o.spp = 4;
  o.directions = "16x32";
  o.shadows = mode;
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

TEST(Energy, WhiteScenesNeverReflectMoreThanTheyReceive) {
  struct Case {
    const char* name;
    std::string scene;
  } cases[] = {{"v-grooves 80°", whiteScene(kGrooves80)},
               {"box cavity", whiteScene(kCavity)},
               {"packed spheres", whiteScene(kPacked)}};
  for (const auto& c : cases)
    for (ShadowMode mode : {ShadowMode::Map, ShadowMode::Rays})
      for (int bounces : {1, 3}) {
        SCOPED_TRACE(std::string(c.name) + ", " + shadowModeName(mode) +
                     ", P = " + std::to_string(bounces));
        const Scene s = test::sceneFromJson(c.scene);
        const auto a = albedos(s, mode, bounces);
        const DirectionSet d = DirectionSet::fromName("16x32");
        double worst = 0;
        int worstL = 0;
        for (int l = 0; l < d.size(); ++l)
          if (a[size_t(l)] > worst) worst = a[size_t(l)], worstL = l;
        std::printf("  %-15s %-4s P=%d: max albedo %.4f at θi %.1f° φi %.1f°\n", c.name,
                    shadowModeName(mode), bounces, worst, rad2deg(d[worstL].theta),
                    rad2deg(d[worstL].phi));
        if (std::getenv("BTF_ENERGY_RINGS")) {
          for (int ring = 0; ring < 16; ++ring) {
            double m = 0;
            for (int k = 0; k < 32; ++k) m = std::max(m, a[size_t(ring * 32 + k)]);
            std::printf("    θi %5.1f°: %.4f\n", rad2deg(d[ring * 32].theta), m);
          }
        }
        EXPECT_LE(worst, 1.03);
      }
}

}  // namespace
}  // namespace btf
