// Materials against independent double-precision formulas, energy bounds and reciprocity.
#include <btf/core/rng.h>
#include <btf/scene/material.h>
#include <gtest/gtest.h>

#include <complex>

#include "test_util.h"

namespace btf {
namespace {

Material ct(const std::string& dist, const std::string& fres, float rough) {
  const Scene s = test::sceneFromJson(
      std::string(R"({"btfscene": 1, "materials": {"m": {"type": "cook_torrance",
     "diffuse": 0.1, "specular": 0.9, "roughness": )") +
      std::to_string(rough) + R"(, "distribution": ")" + dist + R"(", "fresnel": ")" + fres +
      R"(", "f0": [0.9, 0.6, 0.3], "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.1], "ior": 1.5}},
     "parts": [{"type": "plane", "material": "m"}]})");
  return compileMaterial(s.materials[0]);
}

// Reference conductor Fresnel with complex arithmetic (a different derivation from the engine's).
double conductorRef(double cosI, double eta, double k) {
  const std::complex<double> n(eta, k);
  const double s2 = 1 - cosI * cosI;
  const std::complex<double> cosT = std::sqrt(1.0 - s2 / (n * n));
  const std::complex<double> rs = (cosI - n * cosT) / (cosI + n * cosT);
  const std::complex<double> rp = (n * cosI - cosT) / (n * cosI + cosT);
  return 0.5 * (std::norm(rs) + std::norm(rp));
}

TEST(Material, ConductorFresnelMatchesComplexReference) {
  for (double c : {1.0, 0.9, 0.5, 0.2, 0.05, 0.001})
    for (auto [e, k] : {std::pair{0.2, 3.9}, {1.1, 2.1}, {0.05, 4.0}, {2.0, 0.0}})
      EXPECT_NEAR(fresnelConductor(float(c), float(e), float(k)), conductorRef(c, e, k), 2e-4)
          << c << " " << e;
}

TEST(Material, LambertIsAlbedoOverPiAndConservesEnergy) {
  const Scene s = test::sceneFromJson(
      R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": [1, 0.5, 0]}},
     "parts": [{"type": "plane", "material": "m"}]})");
  const Material m = compileMaterial(s.materials[0]);
  const Rgb f = evalBrdf(m, glm::normalize(Vec3(0.3f, 0.1f, 0.9f)), Vec3(0, 0, 1));
  EXPECT_FLOAT_EQ(f.x, float(1 / kPi));
  EXPECT_FLOAT_EQ(f.y, float(0.5 / kPi));
  EXPECT_EQ(f.z, 0.0f);
}

// Directional albedo ∫ f cosθo dωo by stratified integration must not exceed 1 for a
// reflectance-1 conductor-less microfacet lobe with F = 1 (Smith masking only loses energy).
double albedo(const Material& m, const Vec3& wi, int c) {
  const int n = 400;
  double sum = 0;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const double u = (a + 0.5) / n, v = (b + 0.5) / n;
      const double cosT = u, sinT = std::sqrt(1 - u * u), ph = 2 * kPi * v;  // uniform in cosθ
      const Vec3 wo(float(sinT * std::cos(ph)), float(sinT * std::sin(ph)), float(cosT));
      sum += evalBrdf(m, wi, wo)[c] * cosT;
    }
  return sum * 2 * kPi / (double(n) * n);
}

TEST(Material, MicrofacetLobesAreEnergyBoundedAndReciprocal) {
  for (const char* d : {"ggx", "beckmann"})
    for (float r : {0.05f, 0.3f, 1.0f}) {
      Material m = ct(d, "none", r);
      m.kdOverPi = Rgb(0);
      m.ks = Rgb(1);
      for (float th : {0.0f, 0.7f, 1.3f, 1.55f}) {
        const Vec3 wi(std::sin(th), 0, std::cos(th));
        const double a = albedo(m, wi, 0);
        EXPECT_LE(a, 1.01) << d << " α=" << r << " θ=" << th;
        EXPECT_GT(a, (r < 0.5f && th < 1.5f) ? 0.5 : 0.1) << d << " α=" << r << " θ=" << th;
      }
      Rng rng(7);
      for (int k = 0; k < 200; ++k) {
        auto dir = [&] {
          const float z = std::max(0.02f, rng.uniform()), ph = 6.2831853f * rng.uniform();
          const float s = std::sqrt(1 - z * z);
          return Vec3(s * std::cos(ph), s * std::sin(ph), z);
        };
        const Vec3 a = dir(), b = dir();
        const Rgb f1 = evalBrdf(m, a, b), f2 = evalBrdf(m, b, a);
        EXPECT_NEAR(f1.x, f2.x, 1e-4f * std::max(1.0f, f1.x));
      }
    }
}

TEST(Material, FiniteAtGrazingAndNearMirror) {
  for (const char* d : {"ggx", "beckmann"}) {
    const Material m = ct(d, "conductor", 0.001f);
    for (float th : {0.0f, 1.0f, 1.5697f, 1.5707f}) {
      const Vec3 wi(std::sin(th), 0, std::cos(th)), wo(-std::sin(th), 0, std::cos(th));
      const Rgb f = evalBrdf(m, wi, wo);
      EXPECT_TRUE(finite3(f)) << d << " " << th;
      EXPECT_GE(f.x, 0.0f);
    }
  }
  const Scene s = test::sceneFromJson(
      R"({"btfscene": 1, "materials": {"m": {"type": "ward", "alpha_x": 0.002, "alpha_y": 0.002}},
     "parts": [{"type": "plane", "material": "m"}]})");
  const Material w = compileMaterial(s.materials[0]);
  const Rgb f = evalBrdf(w, Vec3(0.99999f, 0, 0.0045f), Vec3(-0.99999f, 0, 0.0045f));
  EXPECT_TRUE(finite3(f));
  EXPECT_EQ(evalBrdf(w, Vec3(0, 0, -1), Vec3(0, 0, 1)), Rgb(0));
}

}  // namespace
}  // namespace btf
