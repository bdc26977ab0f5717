#include <btf/core/error.h>
#include <btf/scene/material.h>

#include <algorithm>
#include <cmath>

namespace btf {

Material compileMaterial(const MaterialDef& def) {
  Material m;
  const ParamSet& p = def.params;
  auto isGrey = [](Vec3 c) { return c.x == c.y && c.y == c.z; };
  if (def.type == "lambert") {
    m.type = BrdfType::Lambert;
    m.kdOverPi = p.v3("albedo") * kInvPiF;
    m.grey = isGrey(p.v3("albedo"));
  } else if (def.type == "blinn_phong") {
    m.type = BrdfType::BlinnPhong;
    m.kdOverPi = p.v3("diffuse") * kInvPiF;
    m.ks = p.v3("specular");
    m.exponent = float(p.f("exponent"));
    m.phongNorm = (m.exponent + 8.0f) / (8.0f * kPiF);
    if (m.exponent >= 0 && m.exponent <= 4096 && std::floor(m.exponent) == m.exponent)
      m.wholeExponent = int(m.exponent);
    m.grey = isGrey(p.v3("diffuse")) && isGrey(m.ks);
  } else if (def.type == "cook_torrance") {
    m.type = BrdfType::CookTorrance;
    m.kdOverPi = p.v3("diffuse") * kInvPiF;
    m.ks = p.v3("specular");
    m.alpha = float(p.f("roughness"));
    m.dist = p.s("distribution") == "beckmann" ? Distribution::Beckmann : Distribution::GGX;
    const std::string& f = p.s("fresnel");
    m.fresnel = f == "none"        ? FresnelMode::None
                : f == "schlick"   ? FresnelMode::Schlick
                : f == "conductor" ? FresnelMode::Conductor
                                   : FresnelMode::Dielectric;
    m.f0 = p.v3("f0");
    m.eta = p.v3("eta");
    m.k = p.v3("k");
    m.ior = float(p.f("ior"));
    m.grey = isGrey(p.v3("diffuse")) && isGrey(m.ks) &&
             (m.fresnel != FresnelMode::Schlick || isGrey(m.f0)) &&
             (m.fresnel != FresnelMode::Conductor || (isGrey(m.eta) && isGrey(m.k)));
  } else if (def.type == "ward") {
    m.type = BrdfType::Ward;
    m.kdOverPi = p.v3("diffuse") * kInvPiF;
    m.ks = p.v3("specular");
    m.alphaX = float(p.f("alpha_x"));
    m.alphaY = float(p.f("alpha_y"));
    m.grey = isGrey(p.v3("diffuse")) && isGrey(m.ks);
  } else {
    throw Error("material '" + def.name + "': unknown type '" + def.type + "'");
  }
  return m;
}

std::vector<Material> compileMaterials(const Scene& scene) {
  std::vector<Material> out;
  for (const auto& m : scene.materials) out.push_back(compileMaterial(m));
  return out;
}

float microfacetD(Distribution d, float alpha, float cosH) {
  if (cosH <= 0) return 0;
  const float c2 = cosH * cosH;
  const float a2 = alpha * alpha;
  if (d == Distribution::Beckmann) {
    const float tan2 = std::max(0.0f, 1 - c2) / c2;
    return std::exp(-tan2 / a2) / (kPiF * a2 * c2 * c2);
  }
  const float t = c2 * (a2 - 1) + 1;
  return a2 / (kPiF * t * t);
}

float smithG1(Distribution d, float alpha, float cosT) {
  if (cosT <= 0) return 0;
  const float c2 = std::min(1.0f, cosT * cosT);
  const float tan2 = (1 - c2) / c2;
  if (d == Distribution::GGX) return 2.0f / (1.0f + std::sqrt(1.0f + alpha * alpha * tan2));
  // Beckmann: exact Λ(a) = (erf(a) − 1)/2 + exp(−a²)/(2a√π), a = 1/(α tanθ).
  if (tan2 <= 0) return 1;
  const float a = 1.0f / (alpha * std::sqrt(tan2));
  if (a > 6) return 1;  // Λ below float precision
  const float lambda = 0.5f * (std::erf(a) - 1.0f) + std::exp(-a * a) / (2.0f * a * 1.7724538509f);
  return 1.0f / (1.0f + lambda);
}

float fresnelDielectric(float cosI, float eta) {
  cosI = std::clamp(cosI, 0.0f, 1.0f);
  const float sin2T = (1 - cosI * cosI) / (eta * eta);
  if (sin2T >= 1) return 1;
  const float cosT = std::sqrt(1 - sin2T);
  const float rs = (cosI - eta * cosT) / (cosI + eta * cosT);
  const float rp = (eta * cosI - cosT) / (eta * cosI + cosT);
  return 0.5f * (rs * rs + rp * rp);
}

float fresnelConductor(float cosI, float eta, float k) {
  // Exact unpolarised Fresnel reflectance of a conductor (air → metal), after pbrt.
  cosI = std::clamp(cosI, 0.0f, 1.0f);
  const float c2 = cosI * cosI, s2 = 1 - c2;
  const float e2 = eta * eta, k2 = k * k;
  const float t0 = e2 - k2 - s2;
  const float a2b2 = std::sqrt(std::max(0.0f, t0 * t0 + 4 * e2 * k2));
  const float a = std::sqrt(std::max(0.0f, 0.5f * (a2b2 + t0)));
  const float t1 = a2b2 + c2, t2 = 2 * cosI * a;
  const float rs = (t1 - t2) / std::max(t1 + t2, 1e-20f);
  const float t3 = c2 * a2b2 + s2 * s2, t4 = t2 * s2;
  const float rp = rs * (t3 - t4) / std::max(t3 + t4, 1e-20f);
  return std::clamp(0.5f * (rp + rs), 0.0f, 1.0f);
}

Rgb fresnel(const Material& m, float cosD) {
  switch (m.fresnel) {
    case FresnelMode::None:
      return Rgb(1);
    case FresnelMode::Schlick: {
      const float x = 1 - std::clamp(cosD, 0.0f, 1.0f);
      const float x5 = (x * x) * (x * x) * x;
      return m.f0 + (Rgb(1) - m.f0) * x5;
    }
    case FresnelMode::Conductor:
      return {fresnelConductor(cosD, m.eta.x, m.k.x), fresnelConductor(cosD, m.eta.y, m.k.y),
              fresnelConductor(cosD, m.eta.z, m.k.z)};
    case FresnelMode::Dielectric:
      return Rgb(fresnelDielectric(cosD, m.ior));
  }
  return Rgb(1);
}

Rgb evalBrdf(const Material& m, const Vec3& wi, const Vec3& wo) {
  if (wi.z <= 0 || wo.z <= 0) return Rgb(0);
  switch (m.type) {
    case BrdfType::Lambert:
      return m.kdOverPi;
    case BrdfType::BlinnPhong: {
      Vec3 h = wi + wo;
      const float l = glm::dot(h, h);
      if (l <= 1e-20f) return m.kdOverPi;
      const float ch = h.z / std::sqrt(l);
      return m.kdOverPi +
             m.ks * (m.phongNorm * powLobe(std::max(ch, 0.0f), m.exponent, m.wholeExponent));
    }
    case BrdfType::CookTorrance: {
      Vec3 h = wi + wo;
      const float l = glm::dot(h, h);
      if (l <= 1e-20f) return m.kdOverPi;
      h *= 1.0f / std::sqrt(l);
      const float D = microfacetD(m.dist, m.alpha, h.z);
      const float G = smithG1(m.dist, m.alpha, wi.z) * smithG1(m.dist, m.alpha, wo.z);
      const Rgb F = fresnel(m, glm::dot(wi, h));
      // Clamp the cosines in the denominator: G → 0 at least as fast, so the limit is finite.
      const float denom = 4.0f * std::max(wi.z, 1e-6f) * std::max(wo.z, 1e-6f);
      return m.kdOverPi + m.ks * F * (D * G / denom);
    }
    case BrdfType::Ward: {
      Vec3 h = wi + wo;
      const float l = glm::dot(h, h);
      if (l <= 1e-20f || h.z <= 0) return m.kdOverPi;
      const float hz2 = h.z * h.z;
      const float e =
          -((h.x * h.x) / (m.alphaX * m.alphaX) + (h.y * h.y) / (m.alphaY * m.alphaY)) / hz2;
      const float spec = std::exp(e) / (4.0f * kPiF * m.alphaX * m.alphaY *
                                        std::sqrt(std::max(wi.z * wo.z, 1e-12f)));
      return m.kdOverPi + m.ks * spec;
    }
  }
  return Rgb(0);
}

}  // namespace btf

namespace btf {

namespace {

float luminance(const Rgb& c) {
  return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
}

Vec3 reflect(const Vec3& wo, const Vec3& h) {
  return 2.0f * glm::dot(wo, h) * h - wo;
}

// Half vector in the local frame from (cos θh, φh).
Vec3 halfFromAngles(float cosT, float phi) {
  const float s = std::sqrt(std::max(0.0f, 1 - cosT * cosT));
  return {s * std::cos(phi), s * std::sin(phi), cosT};
}

// Density of the glossy lobe's half-vector sampler, in solid angle of h.
float pdfHalf(const Material& m, const Vec3& h) {
  if (h.z <= 0) return 0;
  switch (m.type) {
    case BrdfType::Lambert:
      return 0;
    case BrdfType::BlinnPhong:
      return (m.exponent + 1) * (0.5f * kInvPiF) * std::pow(h.z, m.exponent);
    case BrdfType::CookTorrance:
      return microfacetD(m.dist, m.alpha, h.z) * h.z;
    case BrdfType::Ward: {
      const float c2 = h.z * h.z;
      const float e =
          -((h.x * h.x) / (m.alphaX * m.alphaX) + (h.y * h.y) / (m.alphaY * m.alphaY)) / c2;
      return std::exp(e) / (kPiF * m.alphaX * m.alphaY * c2 * h.z);
    }
  }
  return 0;
}

Vec3 sampleHalf(const Material& m, float u1, float u2) {
  const float phi = 2 * kPiF * u2;
  switch (m.type) {
    case BrdfType::Lambert:
      return {0, 0, 1};
    case BrdfType::BlinnPhong:
      return halfFromAngles(std::pow(u1, 1.0f / (m.exponent + 1)), phi);
    case BrdfType::CookTorrance: {
      const float a2 = m.alpha * m.alpha;
      const float tan2 = m.dist == Distribution::GGX ? a2 * u1 / std::max(1 - u1, 1e-7f)
                                                     : -a2 * std::log(std::max(1 - u1, 1e-7f));
      return halfFromAngles(1.0f / std::sqrt(1 + tan2), phi);
    }
    case BrdfType::Ward: {
      // Walter 2005: φh = atan(αy/αx · tan 2πu), tan²θh = −ln u / (cos²φ/αx² + sin²φ/αy²).
      const float ph = std::atan2(m.alphaY * std::sin(phi), m.alphaX * std::cos(phi));
      const float c = std::cos(ph), s = std::sin(ph);
      const float denom = c * c / (m.alphaX * m.alphaX) + s * s / (m.alphaY * m.alphaY);
      const float tan2 = -std::log(std::max(1 - u1, 1e-7f)) / denom;
      return halfFromAngles(1.0f / std::sqrt(1 + tan2), ph);
    }
  }
  return {0, 0, 1};
}

}  // namespace

Rgb evalGlossy(const Material& m, const Vec3& wi, const Vec3& wo) {
  if (m.type == BrdfType::Lambert || wi.z <= 0 || wo.z <= 0) return Rgb(0);
  return glm::max(evalBrdf(m, wi, wo) - m.kdOverPi, Rgb(0));
}

float diffuseLobeWeight(const Material& m) {
  if (m.type == BrdfType::Lambert) return 1;
  const float d = luminance(m.kdOverPi) * kPiF, s = luminance(m.ks);
  if (s <= 0) return 1;
  if (d <= 0) return 0;
  // Keep both techniques alive so that neither lobe is ever undersampled badly.
  return std::clamp(d / (d + s), 0.1f, 0.9f);
}

float pdfGlossyLobe(const Material& m, const Vec3& wo, const Vec3& wi) {
  if (m.type == BrdfType::Lambert || wi.z <= 0 || wo.z <= 0) return 0;
  Vec3 h = wi + wo;
  const float l = glm::dot(h, h);
  if (l <= 1e-20f) return 0;
  h *= 1.0f / std::sqrt(l);
  const float woh = glm::dot(wo, h);
  if (woh <= 0) return 0;
  return pdfHalf(m, h) / (4 * woh);
}

float pdfBrdf(const Material& m, const Vec3& wo, const Vec3& wi) {
  if (wi.z <= 0 || wo.z <= 0) return 0;
  const float pd = diffuseLobeWeight(m);
  float p = pd * wi.z * kInvPiF;
  if (pd < 1) p += (1 - pd) * pdfGlossyLobe(m, wo, wi);
  return p;
}

BrdfSample sampleBrdf(const Material& m, const Vec3& wo, float u0, float u1, float u2) {
  BrdfSample s;
  if (wo.z <= 0) return s;
  const float pd = diffuseLobeWeight(m);
  if (u0 < pd) {
    // Cosine-weighted hemisphere (Malley: concentric-free polar mapping is enough here).
    const float r = std::sqrt(u1), phi = 2 * kPiF * u2;
    s.wi = {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1 - u1))};
  } else {
    const Vec3 h = sampleHalf(m, u1, u2);
    if (glm::dot(wo, h) <= 0) return s;
    s.wi = reflect(wo, h);
  }
  if (s.wi.z <= 0) return s;
  s.pdf = pdfBrdf(m, wo, s.wi);
  return s;
}

float directionalAlbedo(const Material& m, const Vec3& wo, int n) {
  if (wo.z <= 0) return 0;
  Rgb sum(0);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      for (int lobe = 0; lobe < 2; ++lobe) {
        // Stratified over (u1, u2), both lobe choices evaluated with their mixture weight.
        const float pd = diffuseLobeWeight(m);
        const float w = lobe == 0 ? pd : 1 - pd;
        if (w <= 0) continue;
        const BrdfSample s =
            sampleBrdf(m, wo, lobe == 0 ? 0.0f : 1.0f, (a + 0.5f) / n, (b + 0.5f) / n);
        if (s.pdf <= 0) continue;
        // Sample drawn from lobe `lobe` with probability w; the mixture estimator f·cos/pdf
        // already accounts for both lobes, so weight by w.
        sum += w * evalBrdf(m, s.wi, wo) * (s.wi.z / s.pdf);
      }
  sum /= float(n) * float(n);
  return std::max(sum.x, std::max(sum.y, sum.z));
}

float albedoBound(const Material& m) {
  if (m.type == BrdfType::Lambert) {
    const Rgb a = m.kdOverPi * kPiF;
    return std::max(a.x, std::max(a.y, a.z));
  }
  float best = 0;
  for (int k = 0; k <= 12; ++k) {
    const float t = float(k) / 12.0f * 1.5533f;  // up to 89°
    best = std::max(best, directionalAlbedo(m, Vec3(std::sin(t), 0, std::cos(t)), 48));
  }
  return best * 1.05f;
}

}  // namespace btf
