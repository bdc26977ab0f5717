// The shell tables of the GLSL march (RenderScene::gpuTables, shaders/btf_shell.glsl): the
// bounding volume hierarchy, walked without a stack through its skip links as the shader walks
// it, finds the same nearest face as a test of every face, for rays in every direction; every
// face belongs to the prisms that list it, on the side its normal says.
#include <btf/core/rng.h>
#include <btf/render/objects.h>
#include <btf/render/renderer.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace btf {
namespace {

struct Tables {
  const ShellGpuTables& g;
  int si(int i) const { return int(std::floor(g.data[size_t(i)] + 0.5f)); }
  glm::vec3 vertex(int v) const {
    const float* p = &g.data[size_t(g.oVertex + 3 * v)];
    return {p[0], p[1], p[2]};
  }
  // Möller–Trumbore in float, as the shader.
  float hit(int f, glm::vec3 o, glm::vec3 d) const {
    const int b = g.oFace + 6 * f;
    const glm::vec3 v0 = vertex(si(b)), e1 = vertex(si(b + 1)) - v0, e2 = vertex(si(b + 2)) - v0;
    const glm::vec3 pv = glm::cross(d, e2);
    const float det = glm::dot(e1, pv);
    if (det == 0) return std::numeric_limits<float>::infinity();
    const glm::vec3 tv = o - v0;
    const float u = glm::dot(tv, pv) / det;
    const glm::vec3 qv = glm::cross(tv, e1);
    const float v = glm::dot(d, qv) / det;
    if (u < 0 || v < 0 || u + v > 1) return std::numeric_limits<float>::infinity();
    const float t = glm::dot(e2, qv) / det;
    return t > 0 ? t : std::numeric_limits<float>::infinity();
  }
  // The shader's walk: a hit node goes on to the next node, a missed one or a leaf to its skip.
  int walk(glm::vec3 o, glm::vec3 d, float* tBest, int* visited) const {
    int best = -1;
    *tBest = std::numeric_limits<float>::infinity();
    *visited = 0;
    for (int i = 0; i < g.nodes;) {
      ++*visited;
      const float* n = &g.data[size_t(g.oNode + 8 * i)];
      float enter = 0, leave = *tBest;
      for (int k = 0; k < 3; ++k) {
        const float inv = 1 / (std::abs(d[k]) > 1e-30f ? d[k] : 1e-30f);
        float t0 = (n[k] - o[k]) * inv, t1 = (n[3 + k] - o[k]) * inv;
        if (t0 > t1) std::swap(t0, t1);
        enter = std::max(enter, t0), leave = std::min(leave, t1);
      }
      int next = si(g.oNode + 8 * i + 6);
      if (enter <= leave) {
        const int leaf = si(g.oNode + 8 * i + 7);
        if (leaf < 0) {
          next = i + 1;
        } else {
          for (int k = 0; k < si(g.oLeaf + leaf); ++k) {
            const int f = si(g.oLeaf + leaf + 1 + k);
            const float t = hit(f, o, d);
            if (t < *tBest) *tBest = t, best = f;
          }
        }
      }
      i = next;
    }
    return best;
  }
};

TEST(ShellGpu, TheHierarchyFindsTheNearestFaceAsATestOfEveryFace) {
  for (const char* object : {"sphere", "vase"}) {
    RenderSettings s;
    s.tiling = 4;
    const RenderScene rs(makeObject(object), 1.0, 1.0, 0.0, 0.2, s);
    const ShellGpuTables g = rs.gpuTables();
    ASSERT_EQ(size_t(g.faces), rs.shellFaces());
    ASSERT_EQ(size_t(g.prisms), rs.prisms());
    ASSERT_GT(g.nodes, 1);
    const Tables T{g};
    // Every leaf's faces together are every face, once.
    std::vector<int> seen(size_t(g.faces), 0);
    for (int i = 0; i < g.nodes; ++i) {
      const int leaf = T.si(g.oNode + 8 * i + 7);
      if (leaf < 0) continue;
      for (int k = 0; k < T.si(g.oLeaf + leaf); ++k) ++seen[size_t(T.si(g.oLeaf + leaf + 1 + k))];
    }
    for (int f = 0; f < g.faces; ++f) ASSERT_EQ(seen[size_t(f)], 1) << object << " face " << f;
    // Each prism's 8 faces name it on one side.
    for (int p = 0; p < g.prisms; ++p)
      for (int k = 0; k < 8; ++k) {
        const int f = T.si(g.oPrism + 21 * p + k), b = g.oFace + 6 * f;
        ASSERT_TRUE(T.si(b + 3) == p || T.si(b + 4) == p) << object << " prism " << p;
      }
    Rng rng(7);
    const double R = rs.object().radius;
    int hits = 0;
    int64_t visitedSum = 0;
    for (int r = 0; r < 3000; ++r) {
      const double z = 2 * rng.uniformDouble() - 1, a = 2 * kPi * rng.uniformDouble();
      const glm::vec3 from = glm::vec3(float(std::sqrt(1 - z * z) * std::cos(a)),
                                       float(std::sqrt(1 - z * z) * std::sin(a)), float(z)) *
                             float(3 * R);
      const glm::vec3 to(float(R * (rng.uniformDouble() - 0.5)),
                         float(R * (rng.uniformDouble() - 0.5)),
                         float(R * (rng.uniformDouble() - 0.5)));
      const glm::vec3 d = glm::normalize(to - from);
      float tb = 0;
      int visited = 0;
      const int f = T.walk(from, d, &tb, &visited);
      visitedSum += visited;
      float tAll = std::numeric_limits<float>::infinity();
      int fAll = -1;
      for (int k = 0; k < g.faces; ++k) {
        const float t = T.hit(k, from, d);
        if (t < tAll) tAll = t, fAll = k;
      }
      ASSERT_EQ(f >= 0, fAll >= 0) << object << " ray " << r;
      if (fAll < 0) continue;
      ++hits;
      EXPECT_NEAR(tb, tAll, 1e-6 * tAll) << object << " ray " << r;
    }
    EXPECT_GT(hits, 1000) << object;
    // A hierarchy, not a list: a ray visits a small part of the nodes.
    EXPECT_LT(double(visitedSum) / 3000, 0.25 * g.nodes) << object;
  }
}

}  // namespace
}  // namespace btf
