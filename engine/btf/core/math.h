// Small math vocabulary of the engine, on GLM (header-only maths; no GL involved).
#pragma once
#include <cmath>
#include <glm/glm.hpp>

namespace btf {

using Vec2 = glm::vec2;
using Vec3 = glm::vec3;
using DVec3 = glm::dvec3;
using Rgb = glm::vec3;

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr float kPiF = 3.14159265358979323846f;
inline constexpr float kInvPiF = 0.318309886183790671538f;

inline double deg2rad(double d) {
  return d * (kPi / 180.0);
}
inline double rad2deg(double r) {
  return r * (180.0 / kPi);
}

/// Unit direction from spherical angles in radians: θ from +z, φ from +x counter-clockwise.
inline DVec3 sphericalDir(double theta, double phi) {
  const double s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

inline bool finite3(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

/// An orthonormal frame (t, b, n); toLocal maps world vectors to (t, b, n) coordinates.
struct Frame {
  Vec3 t, b, n;
  Vec3 toLocal(const Vec3& v) const { return {glm::dot(v, t), glm::dot(v, b), glm::dot(v, n)}; }
  Vec3 toWorld(const Vec3& v) const { return v.x * t + v.y * b + v.z * n; }
  /// Frame around n whose tangent is the projection of `hint` (falls back to y, then any).
  static Frame fromNormal(const Vec3& n, const Vec3& hint = Vec3(1, 0, 0)) {
    Vec3 t = hint - n * glm::dot(n, hint);
    float l = glm::dot(t, t);
    if (l < 1e-8f) {
      t = Vec3(0, 1, 0) - n * n.y;
      l = glm::dot(t, t);
      if (l < 1e-8f) {
        t = Vec3(0, 0, 1) - n * n.z;
        l = glm::dot(t, t);
      }
    }
    t *= 1.0f / std::sqrt(l);
    return {t, glm::cross(n, t), n};
  }
};

}  // namespace btf
