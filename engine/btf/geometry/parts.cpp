// buildPart: dispatch from a declared part type to its builder, plus the procedural height
// functions (sine, bumps, V-grooves, periodic noise, image) and the swept tube of weaves.
#include <btf/core/error.h>
#include <btf/core/input_file.h>
#include <btf/core/rng.h>
#include <btf/geometry/builders.h>
#include <btf/io/image_io.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <string_view>

namespace btf {

namespace {

constexpr double kTwoPi = 2 * kPi;

/// Periodic gradient noise on a lattice of `period` cells per unit square; one octave.
double gradientNoise(double x, double y, int period, uint64_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int ix = int(fx), iy = int(fy);
  const double tx = x - fx, ty = y - fy;
  auto grad = [&](int i, int j, double dx, double dy) {
    const int wi = ((i % period) + period) % period, wj = ((j % period) + period) % period;
    const double a = kTwoPi * uniformFloat(hashKeys(seed, uint64_t(wi), uint64_t(wj)));
    return std::cos(a) * dx + std::sin(a) * dy;
  };
  auto fade = [](double t) { return t * t * t * (t * (t * 6 - 15) + 10); };
  const double n00 = grad(ix, iy, tx, ty), n10 = grad(ix + 1, iy, tx - 1, ty);
  const double n01 = grad(ix, iy + 1, tx, ty - 1), n11 = grad(ix + 1, iy + 1, tx - 1, ty - 1);
  const double u = fade(tx), v = fade(ty);
  return (n00 * (1 - u) + n10 * u) * (1 - v) + (n01 * (1 - u) + n11 * u) * v;
}

TriMesh buildTube(const Scene& s, const ParamSet& p) {
  const bool alongX = p.s("axis") == "x";
  const double L = alongX ? s.Lx : s.Ly;
  const auto seg = p.i2("segments");
  const double off = p.f("offset"), h = p.f("height"), r = p.f("radius"), A = p.f("amplitude");
  const int w = p.i("waves");
  const double ph = deg2rad(p.f("phase"));
  TriMesh m;
  for (int i = 0; i <= seg[0]; ++i) {
    const double t = double(i) / seg[0];
    const double z = h + A * std::sin(kTwoPi * w * t + ph);
    const double dz = A * kTwoPi * w * std::cos(kTwoPi * w * t + ph) / L;  // dz/ds
    // Frame: T along the centre line, B horizontal across it, N = T × B (upward).
    DVec3 T = alongX ? DVec3(1, 0, dz) : DVec3(0, 1, dz);
    T = glm::normalize(T);
    const DVec3 B = alongX ? DVec3(0, 1, 0) : DVec3(-1, 0, 0);
    const DVec3 N = glm::normalize(glm::cross(T, B));
    const DVec3 c = alongX ? DVec3(t * L, off, z) : DVec3(off, t * L, z);
    for (int j = 0; j < seg[1]; ++j) {
      const double a = kTwoPi * j / seg[1];
      const DVec3 n = std::cos(a) * B + std::sin(a) * N;
      m.pos.push_back(Vec3(c + r * n));
      m.nrm.push_back(Vec3(n));
    }
  }
  auto id = [&](int i, int j) { return uint32_t(i * seg[1] + (j % seg[1])); };
  for (int i = 0; i < seg[0]; ++i)
    for (int j = 0; j < seg[1]; ++j) {
      // Winding chosen so the face normal points outward (along n).
      m.tri.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.tri.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  // Make the winding agree with the outward normals whatever the axis.
  for (auto& t : m.tri) {
    Vec3 fn = glm::cross(m.pos[t.y] - m.pos[t.x], m.pos[t.z] - m.pos[t.x]);
    if (glm::dot(fn, m.nrm[t.x] + m.nrm[t.y] + m.nrm[t.z]) < 0) std::swap(t.y, t.z);
  }
  return m;
}

struct GreyImage {
  int w = 0, h = 0;
  std::vector<float> px;
  // Periodic bilinear; pixel (i, j) is the height at (u, v) = (i / w, j / h), so a grid of the
  // image's own resolution takes the pixel values exactly at its vertices.
  double sample(double u, double v) const {
    const double x = u * w, y = v * h;
    const double fx = std::floor(x), fy = std::floor(y);
    const double tx = x - fx, ty = y - fy;
    auto at = [&](int i, int j) {
      i = ((i % w) + w) % w;
      j = ((j % h) + h) % h;
      return double(px[size_t(j) * w + i]);
    };
    const int i = int(fx), j = int(fy);
    return (at(i, j) * (1 - tx) + at(i + 1, j) * tx) * (1 - ty) +
           (at(i, j + 1) * (1 - tx) + at(i + 1, j + 1) * tx) * ty;
  }
};

GreyImage readGrey(const std::string& path, uint64_t maxPixels) {
  GreyImage g;
  g.px = readHeightImage(path, maxPixels, &g.w, &g.h);
  return g;
}

}  // namespace

std::vector<float> readHeightImage(const std::string& path, uint64_t maxPixels, int* width,
                                   int* height) {
  int w = 0, h = 0, ch = 0;
  // One channel decoded: the first (grey, or red of a colour image).
  const std::vector<float> all = readImageChecked(path, maxPixels, "height image", &w, &h, &ch, 1);
  std::vector<float> px(all.size());
  // Image row 0 is the top, mapped to y = Ly (v = 1).
  for (int64_t j = 0; j < h; ++j)
    for (int64_t i = 0; i < w; ++i) {
      const float v = all[size_t((h - 1 - j) * w + i)];
      if (!std::isfinite(v)) throw Error(path + ": non-finite pixel value in height image");
      px[size_t(j * w + i)] = v;
    }
  *width = w;
  *height = h;
  return px;
}

TriMesh buildPart(const Scene& s, const PartDef& part, uint64_t maxTriangles) {
  const ParamSet& p = part.params;
  const std::string& t = part.type;
  const double Lx = s.Lx, Ly = s.Ly;
  // The declared size of the part, checked before anything is built.
  auto bound = [&](uint64_t tris, const std::string& from) {
    if (tris > maxTriangles)
      throw Error("its " + from + " make " + std::to_string(tris) + " triangles, more than the " +
                  std::to_string(maxTriangles) + " the memory budget allows");
  };
  auto res2 = [&](const char* key) {
    const auto r = p.i2(key);
    return 2 * uint64_t(std::max(r[0], 0)) * uint64_t(std::max(r[1], 0));
  };
  if (t == "sine" || t == "bumps" || t == "noise") bound(res2("resolution"), "resolution");
  if (t == "image") bound(res2("resolution"), "resolution");
  if (t == "vgrooves") bound(4 * uint64_t(p.i("count")) * uint64_t(p.i("subdivisions")), "count");
  if (t == "sphere") bound(uint64_t(p.i("segments")) * uint64_t(p.i("segments")), "segments");
  if (t == "torus" || t == "tube") bound(res2("segments"), "segments");
  if (t == "plane") {
    const float z = float(p.f("height"));
    TriMesh m;
    m.pos = {{0, 0, z}, {float(Lx), 0, z}, {float(Lx), float(Ly), z}, {0, float(Ly), z}};
    m.nrm.assign(4, Vec3(0, 0, 1));
    m.tri = {{0, 1, 2}, {0, 2, 3}};
    return m;
  }
  if (t == "sine") {
    const double A = p.f("amplitude"), ph = deg2rad(p.f("phase")), base = p.f("base");
    const auto per = p.i2("periods");
    const auto res = p.i2("resolution");
    return buildHeightField(
        Lx, Ly, res[0], res[1],
        [=](double x, double y) {
          return base + A * std::sin(kTwoPi * (per[0] * x / Lx + per[1] * y / Ly) + ph);
        },
        false);
  }
  if (t == "bumps") {
    const auto cnt = p.i2("count");
    const auto res = p.i2("resolution");
    const double R = p.f("radius"), H = p.f("height"), base = p.f("base");
    const bool cap = p.s("shape") == "cap";
    const double cx = Lx / cnt[0], cy = Ly / cnt[1];
    return buildHeightField(
        Lx, Ly, res[0], res[1],
        [=](double x, double y) {
          // Offset to the centre of the nearest bump, in units of the cell size.
          const double u = x / cx - std::floor(x / cx) - 0.5, v = y / cy - std::floor(y / cy) - 0.5;
          const double r2 = (u * u + v * v) / (R * R);
          if (cap) return base + (r2 < 1 ? H * std::sqrt(1 - r2) : 0.0);
          return base + H * std::exp(-2.0 * r2);  // σ = R/2
        },
        false);
  }
  if (t == "vgrooves") {
    const int n = p.i("count"), sub = p.i("subdivisions");
    const double d = p.f("depth"), base = p.f("base");
    const bool alongY = p.s("axis") == "y";
    const double L = alongY ? Lx : Ly;  // the profile runs across the grooves
    const int across = 2 * n * sub;
    auto h = [=](double x, double y) {
      const double s = (alongY ? x : y) / L * n;
      const double f = s - std::floor(s);             // position in one groove, [0, 1)
      return base - d * (1 - 2 * std::abs(f - 0.5));  // ridge at f = 0, bottom at f = 1/2
    };
    return alongY ? buildHeightField(Lx, Ly, across, 1, h, true)
                  : buildHeightField(Lx, Ly, 1, across, h, true);
  }
  if (t == "noise") {
    const double A = p.f("amplitude"), gain = p.f("gain"), base = p.f("base");
    const int f0 = p.i("frequency"), oct = p.i("octaves");
    const uint64_t seed = uint64_t(p.i("seed"));
    const auto res = p.i2("resolution");
    return buildHeightField(
        Lx, Ly, res[0], res[1],
        [=](double x, double y) {
          double sum = 0, amp = 1;
          int f = f0;
          for (int o = 0; o < oct; ++o, f *= 2, amp *= gain)
            sum += amp * gradientNoise(x / Lx * f, y / Ly * f, f, seed + uint64_t(o));
          return base + A * sum;
        },
        false);
  }
  if (t == "image") {
    const std::string path = resolvePath(s, p.s("path")).string();
    GreyImage g = readGrey(path, std::max<uint64_t>(maxTriangles / 2, 4));
    auto res = p.i2("resolution");
    if (res[0] == 0) res[0] = g.w;
    if (res[1] == 0) res[1] = g.h;
    bound(2 * uint64_t(res[0]) * uint64_t(res[1]), "image's resolution");
    const double H = p.f("height"), base = p.f("base");
    return buildHeightField(
        Lx, Ly, res[0], res[1],
        [g, H, base, Lx, Ly](double x, double y) { return base + H * g.sample(x / Lx, y / Ly); },
        false);
  }
  if (t == "sphere") return buildSphere(p.v3("center"), float(p.f("radius")), p.i("segments"));
  if (t == "box") return buildBox(p.v3("center"), p.v3("size"));
  if (t == "cylinder")
    return buildCylinder(p.v3("center"), float(p.f("radius")), float(p.f("height")),
                         p.i("segments"), p.b("caps"));
  if (t == "cone")
    return buildCone(p.v3("center"), float(p.f("radius")), float(p.f("height")), p.i("segments"));
  if (t == "torus") {
    const auto seg = p.i2("segments");
    return buildTorus(p.v3("center"), float(p.f("major_radius")), float(p.f("minor_radius")),
                      seg[0], seg[1]);
  }
  if (t == "tube") return buildTube(s, p);
  if (t == "mesh")
    return loadMeshFile(resolvePath(s, p.s("path")).string(), p.b("smooth"), maxTriangles);
  if (t == "subdiv")
    return buildSubdivision(resolvePath(s, p.s("path")).string(), p.i("levels"), p.s("scheme"),
                            false, maxTriangles);
  throw Error("part '" + part.name + "': unknown type '" + t + "'");
}

void applyTransform(TriMesh& m, const ParamSet& tr) {
  const DVec3 t(tr.v3("translate")), r(tr.v3("rotate")), sc(tr.v3("scale"));
  if (t == DVec3(0) && r == DVec3(0) && sc == DVec3(1)) return;
  auto rot = [](int axis, double deg) {
    const double a = deg2rad(deg), c = std::cos(a), s = std::sin(a);
    glm::dmat3 R(1.0);
    const int i = (axis + 1) % 3, j = (axis + 2) % 3;
    R[i][i] = c;
    R[j][j] = c;
    R[i][j] = s;  // column i, row j
    R[j][i] = -s;
    return R;
  };
  const glm::dmat3 S(glm::dvec3(sc.x, 0, 0), glm::dvec3(0, sc.y, 0), glm::dvec3(0, 0, sc.z));
  const glm::dmat3 M = rot(2, r.z) * rot(1, r.y) * rot(0, r.x) * S;
  const glm::dmat3 N = glm::transpose(glm::inverse(M));
  for (auto& p : m.pos) p = Vec3(M * DVec3(p) + t);
  for (auto& n : m.nrm) n = Vec3(glm::normalize(N * DVec3(n)));
}

}  // namespace btf
