// Exact direct light by area against closed forms: the area rasteriser's cell areas, a plane of
// two albedos with its boundary off the texel grid, a box's shadow and its hidden floor, the lit
// fraction of V-groove walls up to grazing light, projected-area conservation on every resource
// scene, and degenerate triangles that change nothing.
#include <btf/geometry/tile_builder.h>
#include <btf/sim/area_raster.h>
#include <btf/sim/exact_direct.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "test_util.h"

namespace btf {
namespace {

using DVec2 = glm::dvec2;

// An independent reference: the area of convex polygon `p` inside the rectangle [x0,x1]×[y0,y1],
// and its first moments ∫x, ∫y there (the polygon formulas).
glm::dvec3 clippedMoments(std::vector<DVec2> p, double x0, double x1, double y0, double y1) {
  auto clip = [&](auto inside, auto cross) {
    std::vector<DVec2> o;
    for (size_t i = 0; i < p.size(); ++i) {
      const DVec2 a = p[i], b = p[(i + 1) % p.size()];
      if (inside(a)) o.push_back(a);
      if (inside(a) != inside(b)) o.push_back(cross(a, b));
    }
    p = o;
  };
  auto atX = [](double x) {
    return [x](DVec2 a, DVec2 b) { return DVec2(x, a.y + (b.y - a.y) * (x - a.x) / (b.x - a.x)); };
  };
  auto atY = [](double y) {
    return [y](DVec2 a, DVec2 b) { return DVec2(a.x + (b.x - a.x) * (y - a.y) / (b.y - a.y), y); };
  };
  clip([&](DVec2 a) { return a.x >= x0; }, atX(x0));
  clip([&](DVec2 a) { return a.x <= x1; }, atX(x1));
  clip([&](DVec2 a) { return a.y >= y0; }, atY(y0));
  clip([&](DVec2 a) { return a.y <= y1; }, atY(y1));
  double s = 0, mx = 0, my = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const DVec2 a = p[i], b = p[(i + 1) % p.size()];
    const double cr = a.x * b.y - b.x * a.y;
    s += cr, mx += (a.x + b.x) * cr, my += (a.y + b.y) * cr;
  }
  const double sg = s < 0 ? -1.0 : 1.0;
  return {sg * 0.5 * s, sg * mx / 6, sg * my / 6};
}

double clippedArea(std::vector<DVec2> p, double x0, double x1, double y0, double y1) {
  return clippedMoments(std::move(p), x0, x1, y0, y1).x;
}

double overlap(double a0, double a1, double b0, double b1) {
  return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
}

void addRing(AreaRaster& r, const std::vector<DVec2>& p, double w) {
  const double ws[3] = {w, 2 * w, -w};
  for (size_t i = 0; i < p.size(); ++i) {
    const DVec2 a = p[i], b = p[(i + 1) % p.size()];
    r.addEdge(a.x, a.y, b.x, b.y, ws);
  }
}

TEST(AreaRaster, CellAreasOfATriangleARectangleWithAHoleAndWrappedCopies) {
  const int nu = 5, nv = 4;
  const std::vector<DVec2> tri = {{0.5, 0.5}, {3.5, 0.7}, {1.2, 2.9}};
  AreaRaster r;
  r.reset(nu, nv, 0, nv, nu + 6);
  addRing(r, tri, 1.0);
  // The same triangle one period to the right and one below: it folds onto itself (× 2 in all).
  std::vector<DVec2> moved;
  for (DVec2 p : tri) moved.push_back(p + DVec2(nu, -nv));
  addRing(r, moved, 1.0);
  // A rectangle with a hole (clockwise inner ring), weight 0.5.
  const std::vector<DVec2> outer = {{0.3, 2.25}, {4.7, 2.25}, {4.7, 3.8}, {0.3, 3.8}};
  const std::vector<DVec2> hole = {{2.1, 2.6}, {2.1, 3.3}, {3.9, 3.3}, {3.9, 2.6}};
  addRing(r, outer, 0.5);
  addRing(r, hole, 0.5);
  r.resolve();
  double total = 0;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double t = clippedArea(tri, i, i + 1, j, j + 1);
      const double rect = overlap(0.3, 4.7, i, i + 1) * overlap(2.25, 3.8, j, j + 1) -
                          overlap(2.1, 3.9, i, i + 1) * overlap(2.6, 3.3, j, j + 1);
      const double want = 2 * t + 0.5 * rect;
      EXPECT_NEAR(r.value(i, j, 0), want, 1e-12) << i << "," << j;
      EXPECT_NEAR(r.value(i, j, 1), 2 * want, 1e-12);
      EXPECT_NEAR(r.value(i, j, 2), -want, 1e-12);
      total += r.value(i, j, 0);
    }
  EXPECT_NEAR(total, 2 * 0.5 * std::abs((3.0 * 2.4) - (0.7 * 0.2)) + 0.5 * (4.4 * 1.55 - 1.8 * 0.7),
              1e-12);
}

TEST(AreaRaster, LinearIntegrandsGiveEachCellTheirExactIntegralFoldedAndWrapped) {
  // f_k(x, y) = a_k + b_k x + g_k y over a triangle (and its copy one period right and one
  // below, which folds onto it) and a rectangle with a hole: every cell gets ∫ f over its part,
  // Σ over the polygons of area · a + b ∫x + g ∫y (the copy at its own, unwrapped, coordinates).
  const int nu = 5, nv = 4;
  const std::vector<DVec2> tri = {{0.5, 0.5}, {3.5, 0.7}, {1.2, 2.9}};
  const std::vector<DVec2> outer = {{0.3, 2.25}, {4.7, 2.25}, {4.7, 3.8}, {0.3, 3.8}};
  const std::vector<DVec2> hole = {{2.1, 2.6}, {2.1, 3.3}, {3.9, 3.3}, {3.9, 2.6}};
  const double a[3] = {0.7, -0.2, 1.5}, b[3] = {0.3, 0.05, -0.4}, g[3] = {-0.25, 0.6, 0.1};
  AreaRaster r;
  r.reset(nu, nv, 0, nv, nu + 6, true);
  auto add = [&](const std::vector<DVec2>& p, DVec2 shift) {
    for (size_t i = 0; i < p.size(); ++i) {
      const DVec2 u = p[i] + shift, v = p[(i + 1) % p.size()] + shift;
      r.addLinearEdge(u.x, u.y, v.x, v.y, a, b, g);
    }
  };
  add(tri, {0, 0});
  add(tri, {nu, -nv});
  add(outer, {0, 0});
  add(hole, {0, 0});
  r.resolve();
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i)
      for (int k = 0; k < 3; ++k) {
        auto f = [&](const glm::dvec3& m) { return a[k] * m.x + b[k] * m.y + g[k] * m.z; };
        // The copy: its part in cell (i + nu, j − nv) has x larger by nu and y smaller by nv.
        const glm::dvec3 c = clippedMoments(tri, i, i + 1, j, j + 1);
        const glm::dvec3 copy = {c.x, c.y + nu * c.x, c.z - nv * c.x};
        glm::dvec3 rect = clippedMoments(outer, i, i + 1, j, j + 1) -
                          clippedMoments(hole, i, i + 1, j, j + 1);
        const double want = f(c) + f(copy) + f(rect);
        EXPECT_NEAR(r.value(i, j, k), want, 1e-12) << i << "," << j << " channel " << k;
      }
  // A constant integrand through the linear path equals addEdge's area.
  AreaRaster flat, lin;
  flat.reset(nu, nv, 0, nv, nu + 6);
  lin.reset(nu, nv, 0, nv, nu + 6, true);
  const double one[3] = {1, 1, 1}, zero[3] = {0, 0, 0};
  for (size_t i = 0; i < tri.size(); ++i) {
    const DVec2 u = tri[i], v = tri[(i + 1) % tri.size()];
    flat.addEdge(u.x, u.y, v.x, v.y, one);
    lin.addLinearEdge(u.x, u.y, v.x, v.y, one, zero, zero);
  }
  flat.resolve();
  lin.resolve();
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) EXPECT_NEAR(lin.value(i, j, 0), flat.value(i, j, 0), 1e-14);
}

// ----- tiles built by hand: flat quads, counter-clockwise seen from their normal's side

void addQuad(TileGeometry& g, DVec3 a, DVec3 b, DVec3 c, DVec3 d, uint16_t mat) {
  const Vec3 n = glm::normalize(Vec3(glm::cross(b - a, c - a)));
  const uint32_t k = uint32_t(g.mesh.pos.size());
  for (DVec3 p : {a, b, c, d}) {
    g.mesh.pos.push_back(Vec3(p));
    g.mesh.nrm.push_back(n);
  }
  g.mesh.tri.push_back({k, k + 1, k + 2});
  g.mesh.tri.push_back({k, k + 2, k + 3});
  g.triMaterial.insert(g.triMaterial.end(), 2, mat);
  g.triPart.insert(g.triPart.end(), 2, 0);
}

Direction dirDeg(double theta, double phi) {
  Direction d;
  d.theta = deg2rad(theta), d.phi = deg2rad(phi);
  d.w = DVec3(std::sin(d.theta) * std::cos(d.phi), std::sin(d.theta) * std::sin(d.phi),
              std::cos(d.theta));
  d.solidAngle = 1;
  return d;
}

Material lambert(double kd) {
  Material m;
  m.type = BrdfType::Lambert;
  m.kdOverPi = Rgb(float(kd / kPi));
  return m;
}

// The box [bx0, bx1] × [by0, by1] × [0, h] (top and four sides) on a floor over the unit tile.
TileGeometry boxOnFloor(double bx0, double bx1, double by0, double by1, double h) {
  TileGeometry g;
  addQuad(g, {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, 0);
  addQuad(g, {bx0, by0, h}, {bx1, by0, h}, {bx1, by1, h}, {bx0, by1, h}, 1);
  addQuad(g, {bx0, by0, 0}, {bx0, by1, 0}, {bx0, by1, h}, {bx0, by0, h}, 1);  // −x
  addQuad(g, {bx1, by0, 0}, {bx1, by0, h}, {bx1, by1, h}, {bx1, by1, 0}, 1);  // +x
  addQuad(g, {bx0, by0, 0}, {bx0, by0, h}, {bx1, by0, h}, {bx1, by0, 0}, 1);  // −y
  addQuad(g, {bx0, by1, 0}, {bx1, by1, 0}, {bx1, by1, h}, {bx0, by1, h}, 1);  // +y
  g.zmin = 0, g.zmax = float(h);
  return g;
}

TEST(ExactDirect, PlaneOfTwoAlbedosWithItsBoundaryOffTheGridAtEveryPair) {
  // Stripes x ∈ [0, 0.37) albedo 0.8, [0.37, 1) albedo 0.2, at height 0.3: seen from ωv the
  // pattern shifts by −0.3 tan θv along φv, wrapped.
  TileGeometry g;
  const double z = 0.3, xb = 0.37;
  addQuad(g, {0, 0, z}, {xb, 0, z}, {xb, 1, z}, {0, 1, z}, 0);
  addQuad(g, {xb, 0, z}, {1, 0, z}, {1, 1, z}, {xb, 1, z}, 1);
  const std::vector<Material> mats = {lambert(0.8), lambert(0.2)};
  const DirectionSet dirs = DirectionSet::subset(
      "t", {dirDeg(0, 0), dirDeg(35, 20), dirDeg(60, 200), dirDeg(85, 110), dirDeg(89, 300)});
  const int n = 8;
  ExactDirect ex(g, mats, dirs, n, n);
  ex.prepare();
  EXPECT_TRUE(ex.allFlat());
  std::vector<float> img(size_t(n) * n * 3);
  int bad = 0;
  for (int v = 0; v < dirs.size(); ++v)
    for (int l = 0; l < dirs.size(); ++l) {
      ex.evalPair(v, l, img.data());
      const double s = -z * dirs[v].w.x / dirs[v].w.z;  // where the stripe x = 0 lands
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          double a = 0;  // area of albedo 0.8 in the texel, over the copies of the stripe
          for (int k = -60; k <= 60; ++k)
            a += overlap(s + k, s + k + xb, double(i) / n, double(i + 1) / n) * n;
          const double want = (0.8 * a + 0.2 * (1 - a)) / kPi;
          bad += std::abs(img[3 * (size_t(j) * n + i)] - want) > 1e-5 * want;
        }
    }
  EXPECT_EQ(bad, 0);
}

TEST(ExactDirect, BoxShadowOnTheFloorAndTheFloorItHidesMatchTheirAreas) {
  const double bx0 = 0.33, bx1 = 0.58, by0 = 0.21, by1 = 0.67, h = 0.2;
  const TileGeometry g = boxOnFloor(bx0, bx1, by0, by1, h);
  const std::vector<Material> mats = {lambert(0.5), lambert(0.9)};
  const DirectionSet dirs = DirectionSet::subset("t", {dirDeg(0, 0), dirDeg(40, 0), dirDeg(40, 180)});
  const int n = 10;
  ExactDirect ex(g, mats, dirs, n, n);
  ex.prepare();
  const double t = h * std::tan(deg2rad(40.0));
  std::vector<float> img(size_t(n) * n * 3);
  auto check = [&](int v, int l, double topShift, double darkX0, double darkX1) {
    ex.evalPair(v, l, img.data());
    double worst = 0;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const double cx0 = double(i) / n, cx1 = double(i + 1) / n;
        const double cy0 = double(j) / n, cy1 = double(j + 1) / n;
        const double top = overlap(bx0 + topShift, bx1 + topShift, cx0, cx1) *
                           overlap(by0, by1, cy0, cy1) * n * n;
        // Floor neither under the top's image nor dark (in shadow, or hidden behind a side that
        // the nadir light does not reach).
        const double dark = overlap(darkX0, darkX1, cx0, cx1) * overlap(by0, by1, cy0, cy1) * n * n;
        const double want = (0.9 * top + 0.5 * (1 - top - dark)) / kPi;
        worst = std::max(worst, std::abs(img[3 * (size_t(j) * n + i)] - want));
      }
    EXPECT_LT(worst, 1e-6) << v << " " << l;
  };
  // Nadir view, light at 40° from +x: the shadow lies on the −x side of the box.
  check(0, 1, 0, bx0 - t, bx0);
  // The reverse pair: seen at 40° from −x, the top lands t further along +x; the floor between
  // the box and the top's image is hidden by the −x side, which the nadir light grazes (zero).
  check(2, 0, t, bx0, bx0 + t);
  // Tile averages of the two pairs agree (Helmholtz reciprocity holds exactly).
  std::vector<float> a(img.size()), b(img.size());
  ex.evalPair(0, 1, a.data());
  ex.evalPair(1, 0, b.data());
  double sa = 0, sb = 0;
  for (size_t k = 0; k < a.size(); k += 3) sa += a[k], sb += b[k];
  EXPECT_NEAR(sa, sb, 1e-6 * sa);
}

// One V-groove across the tile: wall 1 from the ridge at x = 0 down to x = ½ at depth ½ tan α,
// wall 2 back up to x = 1 (triangles 0–1 and 2–3).
TileGeometry vgroove(double alphaDeg) {
  TileGeometry g;
  const double d = 0.5 * std::tan(deg2rad(alphaDeg));
  addQuad(g, {0, 0, 0}, {0.5, 0, -d}, {0.5, 1, -d}, {0, 1, 0}, 0);
  addQuad(g, {0.5, 0, -d}, {1, 0, 0}, {1, 1, 0}, {0.5, 1, -d}, 0);
  g.zmin = float(-d), g.zmax = 0;
  return g;
}

TEST(ExactDirect, VGrooveWallsLitFractionsEqualTheClosedFormUpToGrazing) {
  const double alpha = 50;
  const TileGeometry g = vgroove(alpha);
  std::vector<Direction> ds;
  const std::vector<double> thetas = {0, 20, 39, 41, 55, 70, 80, 85, 88, 89.5};
  for (double th : thetas) ds.push_back(dirDeg(th, 180));  // light from −x: wall 2 faces it
  for (double th : thetas) ds.push_back(dirDeg(th, 0));    // from +x: wall 1 faces it
  for (double th : thetas) ds.push_back(dirDeg(th, 90));   // along the groove: no shadow
  const DirectionSet dirs = DirectionSet::subset("t", ds);
  const std::vector<Material> mats = {lambert(1.0)};
  ExactDirect ex(g, mats, dirs, 16, 16);
  ex.prepare();
  const double ta = std::tan(deg2rad(alpha));
  auto wall = [&](int d, uint32_t first) {  // both triangles have half the wall's area
    return 0.5 * (ex.visibleFraction(d, first) + ex.visibleFraction(d, first + 1));
  };
  for (size_t k = 0; k < thetas.size(); ++k) {
    const double th = deg2rad(thetas[k]);
    const double facing = th == 0 ? 1 : std::min(1.0, 2 / std::tan(th) / (ta + 1 / std::tan(th)));
    const double away = thetas[k] < 90 - alpha ? 1 : 0;
    SCOPED_TRACE(thetas[k]);
    EXPECT_NEAR(wall(int(k), 2), facing, 1e-6);
    EXPECT_NEAR(wall(int(k), 0), away, 1e-6);
    EXPECT_NEAR(wall(int(k + thetas.size()), 0), facing, 1e-6);
    EXPECT_NEAR(wall(int(k + thetas.size()), 2), away, 1e-6);
    EXPECT_NEAR(wall(int(k + 2 * thetas.size()), 0), 1, 1e-6);
    EXPECT_NEAR(wall(int(k + 2 * thetas.size()), 2), 1, 1e-6);
  }
  // The white groove seen from above under each light from −x: the tile average is the closed
  // form, and a closed cavity never reflects more than it receives (direct: ≤ 1/π here).
  std::vector<float> img(16 * 16 * 3);
  for (size_t k = 0; k < thetas.size(); ++k) {
    ex.evalPair(0, int(k), img.data());
    double avg = 0;
    for (size_t q = 0; q < img.size(); q += 3) avg += img[q] / 256.0;
    const double th = deg2rad(thetas[k]), al = deg2rad(alpha);
    const double facing = th == 0 ? 1 : std::min(1.0, 2 / std::tan(th) / (ta + 1 / std::tan(th)));
    const double want = 0.5 / kPi / std::cos(th) *
                        (facing * std::cos(th - al) +
                         (thetas[k] < 90 - alpha ? std::cos(th + al) : 0.0));
    EXPECT_NEAR(avg, want, 1e-6 * std::max(want, 1.0)) << thetas[k];
  }
}

// Every point of the reference plane sees exactly one face: the seen parts' projected areas sum
// to the tile's area from every direction, on every resource scene.
TEST(ExactDirect, SeenAreasPartitionTheTileOnEveryResourceScene) {
  const auto dir = std::filesystem::path(test::sourceDir()) / "resources" / "scenes";
  const DirectionSet dirs = DirectionSet::subset(
      "t", {dirDeg(0, 0), dirDeg(30, 15), dirDeg(60, 100), dirDeg(80, 250)});
  for (const auto& f : std::filesystem::directory_iterator(dir)) {
    if (f.path().extension() != ".json") continue;
    SCOPED_TRACE(f.path().filename().string());
    const Scene s = loadScene(f.path());
    const TileGeometry g = buildTileGeometry(s);
    const auto mats = compileMaterials(s);
    ExactDirect ex(g, mats, dirs, 4, 4);
    ex.setEveryFace(true);
    ex.prepare();
    std::printf("[ measured ] %s: %lld faces, %lld partial, %lld tests, %.2f s\n",
                f.path().filename().c_str(), (long long)ex.stats().faces,
                (long long)ex.stats().partialRegions, (long long)ex.stats().occluderTests,
                ex.stats().hsrSeconds);
    for (int d = 0; d < dirs.size(); ++d) {
      double sum = 0;
      for (uint32_t t = 0; t < g.triangleCount(); ++t) {
        const DVec3 n(g.faceNormal(t));  // length: twice the area
        sum += ex.visibleFraction(d, t) * 0.5 * std::abs(glm::dot(n, dirs[d].w)) / dirs[d].w.z;
      }
      EXPECT_NEAR(sum / (g.Lx * g.Ly), 1.0, 1e-6) << "direction " << d;
    }
    // The simulator's default computes the flat faces' regions only (the smooth ones occlude):
    // the same regions, bit for bit.
    ExactDirect flatOnly(g, mats, dirs, 4, 4);
    flatOnly.prepare();
    for (int d = 0; d < dirs.size(); ++d)
      for (uint32_t t = 0; t < g.triangleCount(); ++t) {
        if (flatOnly.shades(t)) {
          ASSERT_EQ(flatOnly.visibleFraction(d, t), ex.visibleFraction(d, t)) << d << " " << t;
        }
      }
  }
}

TEST(ExactDirect, ChunksOfOneRowGiveTheSameBitsWithTheRowCacheAsWithout) {
  // A run's chunks hold a row or two; the row cache computes a block of rows per view once.
  const auto dir = std::filesystem::path(test::sourceDir()) / "resources" / "scenes";
  const DirectionSet dirs = DirectionSet::subset(
      "t", {dirDeg(0, 0), dirDeg(35, 20), dirDeg(60, 190), dirDeg(78, 300)});
  const int n = 8, nL3 = 3 * dirs.size();
  for (const char* name : {"brick.json", "vgrooves.json"}) {
    SCOPED_TRACE(name);
    const Scene s = loadScene(dir / name);
    const TileGeometry g = buildTileGeometry(s);
    const auto mats = compileMaterials(s);
    ExactDirect plain(g, mats, dirs, n, n), cached(g, mats, dirs, n, n);
    plain.prepare();
    cached.prepare();
    cached.setRowCache(uint64_t(3) * n * dirs.size() * nL3 * sizeof(float));  // 3 rows a block
    int64_t nonzero = 0;
    for (int v = 0; v < dirs.size(); ++v) {
      std::vector<float> a(size_t(n) * n * nL3, -1.f), b(a.size(), -2.f), whole(a.size(), -3.f);
      for (int j = 0; j < n; ++j) {  // one row a call, as chunks of n texels
        plain.evalView(v, int64_t(j) * n, int64_t(j + 1) * n, &a[size_t(j) * n * nL3], nL3);
        cached.evalView(v, int64_t(j) * n, int64_t(j + 1) * n, &b[size_t(j) * n * nL3], nL3);
      }
      plain.evalView(v, 0, int64_t(n) * n, whole.data(), nL3);  // the grid in one call
      for (size_t k = 0; k < a.size(); ++k) {
        ASSERT_EQ(a[k], b[k]) << v << " " << k;
        ASSERT_EQ(a[k], whole[k]) << v << " " << k;
        nonzero += a[k] > 0;
      }
    }
    EXPECT_GT(nonzero, int64_t(n) * n * dirs.size());
  }
}

TEST(ExactDirect, DegenerateTrianglesChangeNothing) {
  const TileGeometry clean = boxOnFloor(0.33, 0.58, 0.21, 0.67, 0.2);
  TileGeometry dirty = clean;
  test::addDegenerateTriangles(dirty);  // zero-area triangles
  // A coincident copy of the box top (same material), and a sliver on the floor's plane.
  for (int k = 0; k < 2; ++k) {
    const glm::uvec3 t = dirty.mesh.tri[size_t(2 + k)];
    dirty.mesh.tri.push_back(t);
    dirty.triMaterial.push_back(1);
    dirty.triPart.push_back(0);
  }
  addQuad(dirty, {0.9, 0.1, 0}, {0.9 + 1e-9, 0.1, 0}, {0.9 + 1e-9, 0.8, 0}, {0.9, 0.8, 0}, 0);
  // A T-junction: the floor's first triangle split at its hypotenuse's midpoint.
  {
    const glm::uvec3 t = dirty.mesh.tri[0];
    const uint32_t m = uint32_t(dirty.mesh.pos.size());
    dirty.mesh.pos.push_back(0.5f * (dirty.mesh.pos[t.x] + dirty.mesh.pos[t.z]));
    dirty.mesh.nrm.push_back(dirty.mesh.nrm[t.x]);
    dirty.mesh.tri[0] = {t.x, t.y, m};
    dirty.mesh.tri.push_back({m, t.y, t.z});
    dirty.triMaterial.push_back(0);
    dirty.triPart.push_back(0);
  }
  const std::vector<Material> mats = {lambert(0.5), lambert(0.9)};
  const DirectionSet dirs =
      DirectionSet::subset("t", {dirDeg(0, 0), dirDeg(50, 30), dirDeg(80, 200), dirDeg(88, 95)});
  const int n = 12;
  ExactDirect a(clean, mats, dirs, n, n), b(dirty, mats, dirs, n, n);
  a.prepare();
  b.prepare();
  std::vector<float> ia(size_t(n) * n * 3), ib(ia.size());
  for (int v = 0; v < dirs.size(); ++v)
    for (int l = 0; l < dirs.size(); ++l) {
      a.evalPair(v, l, ia.data());
      b.evalPair(v, l, ib.data());
      double worst = 0;
      for (size_t k = 0; k < ia.size(); ++k) {
        ASSERT_TRUE(std::isfinite(ib[k]));
        worst = std::max(worst, double(std::abs(ia[k] - ib[k])));
      }
      EXPECT_LT(worst, 1e-6) << v << " " << l;
    }
}

}  // namespace
}  // namespace btf
