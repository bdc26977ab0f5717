// Runtime materials: the declared parameters compiled into a flat struct, and BRDF evaluation
// in the local shading frame (z = shading normal, x = tangent). Values in 1/sr, RGB.
#pragma once
#include <btf/core/math.h>
#include <btf/scene/scene.h>

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
  float alpha = 0.3f;                  // microfacet roughness
  float alphaX = 0.1f, alphaY = 0.1f;  // Ward
  Rgb f0{0.04f}, eta{1}, k{0};
  float ior = 1.5f;
  bool grey = true;  // every RGB parameter has equal channels
};

Material compileMaterial(const MaterialDef& def);
std::vector<Material> compileMaterials(const Scene& scene);

/// f_r(ωi, ωo) with both directions in the local frame (unit vectors). Zero when either is
/// below the surface. Finite for every input, including grazing directions.
Rgb evalBrdf(const Material& m, const Vec3& wi, const Vec3& wo);

// Building blocks, exposed for tests and the analytic references.
float microfacetD(Distribution d, float alpha, float cosThetaH);
float smithG1(Distribution d, float alpha, float cosTheta);
Rgb fresnel(const Material& m, float cosThetaD);
float fresnelDielectric(float cosI, float eta);
float fresnelConductor(float cosI, float eta, float k);

}  // namespace btf
