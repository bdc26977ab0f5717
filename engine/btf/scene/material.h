// Runtime materials: the declared parameters compiled into a flat struct, and BRDF evaluation
// in the local shading frame (z = shading normal, x = tangent). Values in 1/sr, RGB.
#pragma once
#include <btf/core/math.h>
#include <btf/scene/scene.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace btf {

enum class BrdfType : uint8_t { Lambert, BlinnPhong, CookTorrance, Ward };
enum class Distribution : uint8_t { Beckmann, GGX };
enum class FresnelMode : uint8_t { None, Schlick, Conductor, Dielectric };

struct Material {
  BrdfType type = BrdfType::Lambert;
  Distribution dist = Distribution::GGX;
  FresnelMode fresnel = FresnelMode::None;
  Rgb kdOverPi{0};  // diffuse albedo / π
  Rgb ks{0};
  float exponent = 0, phongNorm = 0;   // Blinn-Phong
  int wholeExponent = -1;              // the exponent when a whole number ≤ 4096, else -1
  float alpha = 0.3f;                  // microfacet roughness
  float alphaX = 0.1f, alphaY = 0.1f;  // Ward
  Rgb f0{0.04f}, eta{1}, k{0};
  float ior = 1.5f;
  bool grey = true;  // every RGB parameter has equal channels
};

Material compileMaterial(const MaterialDef& def);

/// x^e for x ≥ 0 — the Blinn-Phong lobe cos^e θh. A whole exponent `whole` ≥ 0 is raised by
/// repeated squaring (a few multiplies, no libm call: the direct kernel spent a quarter of its
/// time in powf); otherwise std::pow.
inline float powLobe(float x, float e, int whole) {
  if (whole < 0) return std::pow(x, e);
  float r = 1.0f, b = x;
  for (unsigned n = unsigned(whole); n; n >>= 1) {
    if (n & 1u) r *= b;
    b *= b;
  }
  return r;
}
std::vector<Material> compileMaterials(const Scene& scene);

/// f_r(ωi, ωo) with both directions in the local frame (unit vectors). Zero when either is
/// below the surface. Finite for every input, including grazing directions.
Rgb evalBrdf(const Material& m, const Vec3& wi, const Vec3& wo);

/// The glossy (non-Lambertian) part of f_r: evalBrdf minus the diffuse term kd/π.
Rgb evalGlossy(const Material& m, const Vec3& wi, const Vec3& wo);

/// Importance sampling of f_r·cos for a fixed ωo (local frame): a one-sample mixture of a
/// cosine-weighted diffuse lobe and the glossy lobe's own sampler (Blinn-Phong cosⁿ on the half
/// vector, D(h)·cos θh for the microfacet distributions, Walter's formula for Ward), so the pdf
/// is the mixture pdf (the balance heuristic over the two techniques).
struct BrdfSample {
  Vec3 wi{0, 0, 1};
  float pdf = 0;  // solid-angle density of wi; 0 when the sample is invalid (below the surface)
};
/// Probability of picking the diffuse lobe (1 for Lambert, 0 when there is no diffuse term).
float diffuseLobeWeight(const Material& m);
BrdfSample sampleBrdf(const Material& m, const Vec3& wo, float u0, float u1, float u2);
/// Density of sampleBrdf's output wi given wo (0 below the surface).
float pdfBrdf(const Material& m, const Vec3& wo, const Vec3& wi);
/// Density of the glossy lobe's sampler alone (0 for Lambert).
float pdfGlossyLobe(const Material& m, const Vec3& wo, const Vec3& wi);
/// Directional albedo ρ(ωo) = ∫ f_r(ωi, ωo) cos θi dωi (max over RGB), by importance sampling
/// with n×n stratified samples (deterministic).
float directionalAlbedo(const Material& m, const Vec3& wo, int n = 64);
/// An upper bound of the directional albedo over all ωo (max over a θ sweep, plus 5 %): the ρ_max
/// of the effect planner's energy bound.
float albedoBound(const Material& m);

// Building blocks, exposed for tests and the analytic references.
float microfacetD(Distribution d, float alpha, float cosThetaH);
float smithG1(Distribution d, float alpha, float cosTheta);
Rgb fresnel(const Material& m, float cosThetaD);
float fresnelDielectric(float cosI, float eta);
float fresnelConductor(float cosI, float eta, float k);

}  // namespace btf
