#include <btf/compress/halfway.h>
#include <btf/core/error.h>

#include <algorithm>
#include <cmath>

namespace btf {

namespace {

// (θ, φ) of a direction; one below the horizon is taken on it (the interpolation clamps to the
// last ring there).
void angles(DVec3 w, double& theta, double& phi) {
  w.z = std::max(w.z, 0.0);
  const double len = std::sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
  if (!(len > 1e-12)) {
    theta = 0, phi = 0;
    return;
  }
  theta = std::acos(std::clamp(w.z / len, -1.0, 1.0));
  phi = std::atan2(w.y, w.x);
  if (phi < 0) phi += 2 * kPi;
}

}  // namespace

HalfwayMap::HalfwayMap(const DirectionSet& set) : m_n(set.size()) {
  if (m_n < 1 || m_n > 65535)
    throw Error("half-vector reparameterisation: " + std::to_string(m_n) +
                " directions (1 … 65535)");
  m_forward.resize(size_t(m_n) * m_n);
  m_inverse.resize(size_t(m_n) * m_n);
  auto taps = [&](double theta, double phi) {
    DirWeight w[4];
    const int k = set.interpolate(theta, phi, w);
    Taps t{};
    t.count = k;
    for (int i = 0; i < k; ++i) t.index[i] = uint16_t(w[i].index), t.weight[i] = float(w[i].weight);
    return t;
  };
  for (int v = 0; v < m_n; ++v) {
    const DVec3 wv = set[v].w;
    for (int j = 0; j < m_n; ++j) {
      // Forward: the light whose half vector with v is h_j.
      const DVec3 h = set[j].w;
      const DVec3 l = 2.0 * glm::dot(wv, h) * h - wv;
      double theta, phi;
      angles(l, theta, phi);
      m_forward[size_t(v) * m_n + j] = taps(theta, phi);
      // Inverse: the half vector of (v, l_j).
      angles(wv + set[j].w, theta, phi);
      m_inverse[size_t(v) * m_n + j] = taps(theta, phi);
    }
  }
}

void HalfwayMap::apply(const std::vector<Taps>& taps, int n, const float* in, float* out,
                       int channels) {
  for (int v = 0; v < n; ++v) {
    const float* row = in + size_t(v) * n * channels;
    for (int j = 0; j < n; ++j) {
      const Taps& t = taps[size_t(v) * n + j];
      float* o = out + (size_t(v) * n + j) * channels;
      for (int c = 0; c < channels; ++c) {
        float s = 0;
        for (int i = 0; i < t.count; ++i) s += t.weight[i] * row[size_t(t.index[i]) * channels + c];
        o[c] = s;
      }
    }
  }
}

void HalfwayMap::forward(const float* in, float* out, int channels) const {
  apply(m_forward, m_n, in, out, channels);
}
void HalfwayMap::inverse(const float* in, float* out, int channels) const {
  apply(m_inverse, m_n, in, out, channels);
}

int HalfwayMap::inverseTaps(int view, int light, DirWeight out[4]) const {
  const Taps& t = m_inverse[size_t(view) * m_n + light];
  for (int i = 0; i < t.count; ++i) out[i] = {int(t.index[i]), double(t.weight[i])};
  return t.count;
}

}  // namespace btf
