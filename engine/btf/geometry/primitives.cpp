#include <btf/geometry/builders.h>

namespace btf {

namespace {
constexpr float kTwoPi = 6.28318530718f;
}

TriMesh buildSphere(Vec3 c, float r, int seg) {
  TriMesh m;
  const int rings = std::max(2, seg / 2);
  // Poles are single vertices with triangle fans, so no zero-area triangles are produced.
  m.pos.push_back(c + Vec3(0, 0, r));
  m.nrm.push_back(Vec3(0, 0, 1));
  for (int i = 1; i < rings; ++i) {
    const float th = float(kPi) * i / rings;
    for (int j = 0; j < seg; ++j) {
      const float ph = kTwoPi * j / seg;
      Vec3 n(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
      m.pos.push_back(c + r * n);
      m.nrm.push_back(n);
    }
  }
  m.pos.push_back(c - Vec3(0, 0, r));
  m.nrm.push_back(Vec3(0, 0, -1));
  const uint32_t south = uint32_t(m.pos.size() - 1);
  auto v = [&](int ring, int j) { return uint32_t(1 + (ring - 1) * seg + (j % seg)); };
  for (int j = 0; j < seg; ++j) m.tri.push_back({0, v(1, j), v(1, j + 1)});
  for (int i = 1; i < rings - 1; ++i)
    for (int j = 0; j < seg; ++j) {
      m.tri.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
      m.tri.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  for (int j = 0; j < seg; ++j) m.tri.push_back({south, v(rings - 1, j + 1), v(rings - 1, j)});
  return m;
}

TriMesh buildBox(Vec3 c, Vec3 s) {
  TriMesh m;
  const Vec3 h = 0.5f * s;
  const Vec3 n[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const Vec3& f : n) {
    // Two tangents u, w with u × w = f.
    Vec3 u = std::abs(f.z) > 0.5f ? Vec3(1, 0, 0) : Vec3(0, 0, 1);
    Vec3 w = glm::cross(f, u);
    u = glm::cross(w, f);
    const uint32_t k = uint32_t(m.pos.size());
    const float su[4] = {-1, 1, 1, -1}, sw[4] = {-1, -1, 1, 1};
    for (int q = 0; q < 4; ++q) {
      m.pos.push_back(c + h * (f + su[q] * u + sw[q] * w));
      m.nrm.push_back(f);
    }
    m.tri.push_back({k, k + 1, k + 2});
    m.tri.push_back({k, k + 2, k + 3});
  }
  return m;
}

namespace {
void addDisk(TriMesh& m, Vec3 centre, float r, int seg, bool up) {
  const uint32_t k = uint32_t(m.pos.size());
  const Vec3 n(0, 0, up ? 1.f : -1.f);
  m.pos.push_back(centre);
  m.nrm.push_back(n);
  for (int j = 0; j < seg; ++j) {
    const float ph = kTwoPi * j / seg;
    m.pos.push_back(centre + Vec3(r * std::cos(ph), r * std::sin(ph), 0));
    m.nrm.push_back(n);
  }
  for (int j = 0; j < seg; ++j) {
    uint32_t a = k + 1 + j, b = k + 1 + (j + 1) % seg;
    if (up)
      m.tri.push_back({k, a, b});
    else
      m.tri.push_back({k, b, a});
  }
}
}  // namespace

TriMesh buildCylinder(Vec3 base, float r, float h, int seg, bool caps) {
  TriMesh m;
  for (int j = 0; j < seg; ++j) {
    const float ph = kTwoPi * j / seg;
    Vec3 n(std::cos(ph), std::sin(ph), 0);
    m.pos.push_back(base + r * n);
    m.nrm.push_back(n);
    m.pos.push_back(base + r * n + Vec3(0, 0, h));
    m.nrm.push_back(n);
  }
  for (int j = 0; j < seg; ++j) {
    uint32_t a = 2 * j, b = 2 * ((j + 1) % seg);
    m.tri.push_back({a, b, b + 1});
    m.tri.push_back({a, b + 1, a + 1});
  }
  if (caps) {
    addDisk(m, base, r, seg, false);
    addDisk(m, base + Vec3(0, 0, h), r, seg, true);
  }
  return m;
}

TriMesh buildCone(Vec3 base, float r, float h, int seg) {
  TriMesh m;
  const float s = std::sqrt(r * r + h * h);
  for (int j = 0; j < seg; ++j) {
    const float ph0 = kTwoPi * j / seg, ph1 = kTwoPi * (j + 1) / seg, phm = 0.5f * (ph0 + ph1);
    auto nAt = [&](float ph) { return Vec3(h * std::cos(ph) / s, h * std::sin(ph) / s, r / s); };
    const uint32_t k = uint32_t(m.pos.size());
    m.pos.push_back(base + Vec3(r * std::cos(ph0), r * std::sin(ph0), 0));
    m.nrm.push_back(nAt(ph0));
    m.pos.push_back(base + Vec3(r * std::cos(ph1), r * std::sin(ph1), 0));
    m.nrm.push_back(nAt(ph1));
    m.pos.push_back(base + Vec3(0, 0, h));  // apex: one vertex per facet, normal of its middle
    m.nrm.push_back(nAt(phm));
    m.tri.push_back({k, k + 1, k + 2});
  }
  addDisk(m, base, r, seg, false);
  return m;
}

TriMesh buildTorus(Vec3 c, float R, float r, int nu, int nv) {
  TriMesh m;
  for (int i = 0; i < nu; ++i) {
    const float u = kTwoPi * i / nu;
    for (int j = 0; j < nv; ++j) {
      const float v = kTwoPi * j / nv;
      Vec3 n(std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v));
      m.pos.push_back(c + Vec3(R * std::cos(u), R * std::sin(u), 0) + r * n);
      m.nrm.push_back(n);
    }
  }
  auto id = [&](int i, int j) { return uint32_t((i % nu) * nv + (j % nv)); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.tri.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.tri.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

}  // namespace btf
