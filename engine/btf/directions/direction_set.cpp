#include <btf/core/error.h>
#include <btf/directions/direction_set.h>

#include <cmath>
#include <cstdio>

namespace btf {

DirectionSet DirectionSet::grid(int nTheta, int nPhi) {
  if (nTheta < 1 || nPhi < 1 || nTheta > 4096 || nPhi > 8192)
    throw Error("invalid direction grid " + std::to_string(nTheta) + "x" + std::to_string(nPhi) +
                ": both counts must be between 1 and 4096 (θ) / 8192 (φ)");
  DirectionSet s;
  s.m_name = std::to_string(nTheta) + "x" + std::to_string(nPhi);
  s.m_grid = true;
  for (int k = 0; k < nTheta; ++k)
    s.m_rings.push_back({(k + 0.5) * (kPi / 2) / nTheta, nPhi, 0.5 * 2 * kPi / nPhi, 0});
  s.finish(true);
  return s;
}

DirectionSet DirectionSet::axisGrid(int nTheta, int nPhi) {
  if (nTheta < 2 || nTheta > 4096 || nPhi < 4 || nPhi > 8192 || nPhi % 4 != 0)
    throw Error("invalid direction grid " + std::to_string(nTheta) + "x" + std::to_string(nPhi) +
                "a: θ count 2..4096, φ count 4..8192 and a multiple of 4 (so that φ = 0°, 90°, "
                "180° and 270° are directions)");
  DirectionSet s;
  s.m_name = std::to_string(nTheta) + "x" + std::to_string(nPhi) + "a";
  // The pole, then rings at k·90°/Nθ with azimuths from φ = 0: axis-aligned geometry's ridges
  // (φ = 0°, 90°, 180°, 270°) fall on directions instead of between them.
  s.m_rings.push_back({0.0, 1, 0.0, 0});
  for (int k = 1; k < nTheta; ++k) s.m_rings.push_back({k * (kPi / 2) / nTheta, nPhi, 0.0, 0});
  s.finish(false);
  return s;
}

DirectionSet DirectionSet::fromRings(const std::string& name,
                                     const std::vector<std::array<double, 3>>& ringsDeg) {
  DirectionSet s;
  s.m_name = name;
  for (const auto& r : ringsDeg) s.m_rings.push_back({deg2rad(r[0]), int(r[1]), deg2rad(r[2]), 0});
  s.finish(false);
  return s;
}

DirectionSet DirectionSet::subset(const std::string& name, const std::vector<Direction>& dirs) {
  BTF_CHECK(!dirs.empty());
  DirectionSet s;
  s.m_name = name;
  s.m_dirs = dirs;
  for (size_t i = 0; i < dirs.size(); ++i)
    s.m_rings.push_back({dirs[i].theta, 1, dirs[i].phi, int(i)});
  return s;
}

DirectionSet DirectionSet::bonn81() {
  // UBO2003: θ = 0, 15, 30, 45, 60, 75° with 1, 6, 12, 18, 20, 24 azimuths (81 in all).
  return fromRings("bonn81",
                   {{0, 1, 0}, {15, 6, 0}, {30, 12, 0}, {45, 18, 0}, {60, 20, 0}, {75, 24, 0}});
}

DirectionSet DirectionSet::ubo151() {
  return fromRings("ubo151", {{0, 1, 0},
                              {11, 6, 15},
                              {23.5, 12, 0},
                              {30, 12, 15},
                              {37.5, 12, 0},
                              {45, 18, 0},
                              {52.5, 18, 7.5},
                              {60, 24, 0},
                              {67.5, 24, 7.5},
                              {75, 24, 0}});
}

DirectionSet DirectionSet::fromName(const std::string& n) {
  if (n == "bonn81") return bonn81();
  if (n == "ubo151") return ubo151();
  std::string g = n.rfind("grid:", 0) == 0 ? n.substr(5) : n;
  int a = 0, b = 0;
  char x = 0, extra = 0;
  const int got = std::sscanf(g.c_str(), "%d%c%d%c", &a, &x, &b, &extra);
  if (got == 3 && (x == 'x' || x == 'X')) return grid(a, b);
  char extra2 = 0;
  if (got == 4 && (x == 'x' || x == 'X') && extra == 'a' &&
      std::sscanf(g.c_str(), "%d%c%d%c%c", &a, &x, &b, &extra, &extra2) == 4)
    return axisGrid(a, b);
  throw Error("unknown direction set '" + n +
              "' (expected bonn81, ubo151, a θ×φ grid like 16x32, or one with azimuths on the "
              "axes like 16x32a)");
}

void DirectionSet::finish(bool gridCells) {
  // Ring bands: a grid's cells are its θ rectangles; other sets use the midpoints between
  // consecutive rings, the first band starting at 0 and the last ending at 90°.
  const size_t nr = m_rings.size();
  std::vector<double> lo(nr), hi(nr);
  for (size_t r = 0; r < nr; ++r) {
    if (gridCells) {
      const double step = (kPi / 2) / double(nr);
      lo[r] = r * step;
      hi[r] = (r + 1) * step;
    } else {
      lo[r] = r == 0 ? 0 : 0.5 * (m_rings[r - 1].theta + m_rings[r].theta);
      hi[r] = r + 1 == nr ? kPi / 2 : 0.5 * (m_rings[r].theta + m_rings[r + 1].theta);
    }
  }
  m_dirs.clear();
  for (size_t r = 0; r < nr; ++r) {
    auto& ring = m_rings[r];
    BTF_CHECK(ring.count >= 1);
    ring.first = int(m_dirs.size());
    const double band = 2 * kPi * (std::cos(lo[r]) - std::cos(hi[r]));
    for (int j = 0; j < ring.count; ++j) {
      Direction d;
      d.theta = ring.theta;
      d.phi = ring.phiOffset + 2 * kPi * j / ring.count;
      d.phi = std::fmod(d.phi, 2 * kPi);
      d.w = sphericalDir(d.theta, d.phi);
      d.solidAngle = band / ring.count;
      m_dirs.push_back(d);
    }
  }
}

int DirectionSet::nearest(const DVec3& w) const {
  int best = 0;
  double bd = -2;
  for (int i = 0; i < size(); ++i) {
    const double d = glm::dot(w, m_dirs[size_t(i)].w);
    if (d > bd) {
      bd = d;
      best = i;
    }
  }
  return best;
}

int DirectionSet::interpolate(double theta, double phi, DirWeight out[4]) const {
  int n = 0;
  const size_t nr = m_rings.size();
  auto inRing = [&](const DirectionRing& r, double wRing) {
    if (r.count == 1) {
      out[n++] = {r.first, wRing};
      return;
    }
    const double step = 2 * kPi / r.count;
    double x = (phi - r.phiOffset) / step;
    x -= std::floor(x / r.count) * r.count;  // wrap into [0, count)
    int j0 = int(std::floor(x));
    const double f = x - j0;
    j0 %= r.count;
    const int j1 = (j0 + 1) % r.count;
    out[n++] = {r.first + j0, wRing * (1 - f)};
    if (f > 0) out[n++] = {r.first + j1, wRing * f};
  };
  if (theta <= m_rings.front().theta || nr == 1) {
    inRing(m_rings.front(), 1);
  } else if (theta >= m_rings.back().theta) {
    inRing(m_rings.back(), 1);
  } else {
    size_t r = 0;
    while (r + 1 < nr && m_rings[r + 1].theta < theta) ++r;
    const double f = (theta - m_rings[r].theta) / (m_rings[r + 1].theta - m_rings[r].theta);
    inRing(m_rings[r], 1 - f);
    if (f > 0) inRing(m_rings[r + 1], f);
  }
  return n;
}

std::vector<DirWeight> DirectionSet::interpolate(double theta, double phi) const {
  DirWeight w[4];
  const int n = interpolate(theta, phi, w);
  return std::vector<DirWeight>(w, w + n);
}

}  // namespace btf
