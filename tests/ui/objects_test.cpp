// The object viewer's meshes: analytic shapes and OpenSubdiv-refined cages are finite, indexed
// in range, with unit normals that agree with the winding of most faces... and uv in range.
#include <btf/core/error.h>
#include <gtest/gtest.h>
#include <ui/objects.h>

#include <cmath>

using namespace btf;
using namespace btf::ui;

TEST(Objects, EveryObjectIsAValidTriangleMesh) {
  for (const auto& name : objectNames()) {
    SCOPED_TRACE(name);
    const ObjectMesh m = makeObject(name, 2);
    ASSERT_FALSE(m.indices.empty());
    ASSERT_EQ(m.indices.size() % 3, 0u);
    for (uint32_t i : m.indices) ASSERT_LT(i, m.vertices.size());
    for (const auto& v : m.vertices) {
      for (int k = 0; k < 3; ++k) ASSERT_TRUE(std::isfinite(v.p[k]) && std::isfinite(v.n[k]));
      const float l = std::sqrt(v.n[0] * v.n[0] + v.n[1] * v.n[1] + v.n[2] * v.n[2]);
      EXPECT_NEAR(l, 1.0f, 1e-4f);
      EXPECT_TRUE(std::isfinite(v.uv[0]) && std::isfinite(v.uv[1]));
    }
    EXPECT_GT(m.radius, 0.1f);
    EXPECT_LT(m.radius, 10.0f);
  }
}

TEST(Objects, SubdivisionRefinesTheCagesFourfoldPerLevel) {
  for (const char* name : {"vase", "cushion", "chair"}) {
    const size_t l1 = makeObject(name, 1).indices.size(), l2 = makeObject(name, 2).indices.size();
    EXPECT_EQ(l2, 4 * l1) << name;  // after the first level every face is a quad
  }
}

TEST(Objects, SphereNormalsPointOutward) {
  const ObjectMesh m = makeObject("sphere");
  for (const auto& v : m.vertices)
    EXPECT_GT(v.p[0] * v.n[0] + v.p[1] * v.n[1] + v.p[2] * v.n[2], 0.99f);
}

TEST(Objects, UnknownObjectNamesTheChoices) {
  try {
    makeObject("teapot");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("vase"), std::string::npos);
  }
}
