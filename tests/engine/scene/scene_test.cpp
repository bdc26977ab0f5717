// Scene file: round trip through the writer, and every bad input is a clear error that names
// the file, the JSON path (or line) and the rule.
#include <btf/core/error.h>
#include <btf/geometry/tile_builder.h>
#include <btf/scene/scene.h>
#include <gtest/gtest.h>

#include <fstream>

#include "test_util.h"

namespace btf {
namespace {

const char* kMinimal = R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
  "parts": [{"type": "plane", "material": "m"}]})";

std::string errorOf(const std::string& json, const std::filesystem::path& dir = {}) {
  try {
    Scene s = test::sceneFromJson(json, dir);
    buildTileGeometry(s);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(SceneFile, EveryResourceSceneLoadsBuildsAndRoundTrips) {
  const auto dir = std::filesystem::path(test::sourceDir()) / "resources" / "scenes";
  int n = 0;
  for (const auto& f : std::filesystem::directory_iterator(dir)) {
    if (f.path().extension() != ".json") continue;
    SCOPED_TRACE(f.path().string());
    const Scene s = loadScene(f.path());
    const TileGeometry g = buildTileGeometry(s);
    EXPECT_GT(g.triangleCount(), 0u);
    // Writer output parses back to the same scene, and writing again gives the same text.
    const std::string j = sceneToJson(s);
    const Scene back = parseScene(j, "roundtrip.json", s.baseDir);
    EXPECT_EQ(back, s);
    EXPECT_EQ(sceneToJson(back), j);
    ++n;
  }
  EXPECT_GE(n, 9);
}

TEST(SceneFile, DefaultsFillEveryDeclaredParameter) {
  const Scene s = test::sceneFromJson(kMinimal);
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_FLOAT_EQ(s.materials[0].params.v3("albedo").x, 0.8f);
  EXPECT_EQ(s.simulation.s("directions"), "bonn81");
  EXPECT_EQ(s.Lx, 1.0);
}

TEST(SceneFile, MalformedJsonNamesTheLine) {
  const std::string e = errorOf("{\n\"btfscene\": 1,\n\"materials\": {,\n}");
  EXPECT_NE(e.find("test.json:3"), std::string::npos) << e;
  EXPECT_NE(e.find("JSON syntax error"), std::string::npos) << e;
}

TEST(SceneFile, UnknownKeyNamesThePathAndTheKnownKeys) {
  const std::string e =
      errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albdo": 0.5}},
    "parts": [{"type": "plane", "material": "m"}]})");
  EXPECT_NE(e.find("materials.m.albdo"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key"), std::string::npos) << e;
  EXPECT_NE(e.find("albedo"), std::string::npos) << e;
  EXPECT_NE(errorOf(R"({"btfscene": 1, "materialz": {}, "materials": {}, "parts": []})")
                .find("materialz"),
            std::string::npos);
}

TEST(SceneFile, WrongTypeAndRangeAreErrors) {
  std::string e =
      errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": "red"}},
    "parts": [{"type": "plane", "material": "m"}]})");
  EXPECT_NE(e.find("materials.m.albedo: expected an RGB triple, got string"), std::string::npos)
      << e;
  e = errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": [0.5, 2, 0.5]}},
    "parts": [{"type": "plane", "material": "m"}]})");
  EXPECT_NE(e.find("materials.m.albedo[1]: must be <= 1 (got 2)"), std::string::npos) << e;
  e = errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "sphere", "material": "m", "radius": -1}]})");
  EXPECT_NE(e.find("parts[0].radius: must be > 0 (got -1)"), std::string::npos) << e;
  e = errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "sine", "material": "m", "resolution": [0, 8]}]})");
  EXPECT_NE(e.find("parts[0].resolution[0]: must be >= 2 (got 0)"), std::string::npos) << e;
  e = errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "plane", "material": "m"}], "simulation": {"texels": [0, 4]}})");
  EXPECT_NE(e.find("simulation.texels[0]: must be >= 1 (got 0)"), std::string::npos) << e;
  e = errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "sine", "material": "m", "periods": [1.5, 0]}]})");
  EXPECT_NE(e.find("parts[0].periods[0]: expected an integer"), std::string::npos) << e;
}

TEST(SceneFile, NonFiniteNumbersAreErrors) {
  // JSON has no NaN literal; NaN and an overflowing literal are rejected with the line.
  std::string e = errorOf(
      "{\"btfscene\": 1, \"materials\": {\"m\": {\"type\": \"lambert\"}},\n"
      "\"parts\": [{\"type\": \"plane\", \"material\": \"m\", \"height\": 1e999}]}");
  EXPECT_NE(e.find("test.json:2: the number 1e999 is beyond the range of a double"),
            std::string::npos)
      << e;
  EXPECT_EQ(e.find("json.exception"), std::string::npos) << e;
  e = errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": NaN}},
    "parts": [{"type": "plane", "material": "m"}]})");
  EXPECT_NE(e.find("test.json:1:66: JSON syntax error near"), std::string::npos) << e;
  EXPECT_EQ(e.find("json.exception"), std::string::npos) << e;
}

TEST(SceneFile, StructuralErrors) {
  EXPECT_NE(errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}}, "parts": []})")
                .find("the scene is empty"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"btfscene": 2, "materials": {}, "parts": []})")
                .find("unsupported scene format version"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "plane", "material": "x"}]})")
                .find("parts[0].material: no material named 'x'"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "velvet"}},
    "parts": [{"type": "plane", "material": "m"}]})")
                .find("unknown material type 'velvet'"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "blob", "material": "m"}]})")
                .find("parts[0].type: unknown part type 'blob'"),
            std::string::npos);
  EXPECT_NE(
      errorOf(
          R"({"btfscene": 1, "materials": {"m": {"type": "cook_torrance", "distribution": "phong"}},
    "parts": [{"type": "plane", "material": "m"}]})")
          .find("unknown value 'phong'"),
      std::string::npos);
}

TEST(SceneFile, MeshErrorsNameTheFile) {
  const auto dir = test::tempDir("meshes");
  std::ofstream(dir / "degenerate.obj") << "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
  std::ofstream(dir / "repeated.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n";
  // Three triangles on one edge: non-manifold.
  std::ofstream(dir / "fan.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\n"
                                    "f 1 2 3\nf 2 1 4\nf 1 2 5\n";
  auto scene = [](const std::string& file) {
    return std::string(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
      "parts": [{"type": "mesh", "material": "m", "path": ")") +
           file + R"("}]})";
  };
  std::string e = errorOf(scene("missing.obj"), dir);
  EXPECT_NE(e.find("missing.obj: mesh file not found"), std::string::npos) << e;
  EXPECT_NE(e.find("parts[0]"), std::string::npos) << e;
  e = errorOf(scene("degenerate.obj"), dir);
  EXPECT_NE(e.find("degenerate.obj: degenerate mesh"), std::string::npos) << e;
  e = errorOf(scene("repeated.obj"), dir);
  EXPECT_NE(e.find("repeated.obj: mesh has no faces"), std::string::npos)
      << e;  // OpenMesh drops the face
  e = errorOf(scene("fan.obj"), dir);
  EXPECT_NE(e.find("fan.obj: non-manifold mesh"), std::string::npos) << e;
  e = errorOf(std::string(R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
      "parts": [{"type": "mesh", "material": "m"}]})"),
              dir);
  EXPECT_NE(e.find("missing required key 'path'"), std::string::npos) << e;
}

TEST(SceneFile, SchemaDeclaresEveryTypeAndIsCommitted) {
  const std::string schema = sceneJsonSchema();
  for (const auto& t : materialTypes())
    EXPECT_NE(schema.find("\"const\": \"" + t.name + "\""), std::string::npos);
  for (const auto& t : partTypes())
    EXPECT_NE(schema.find("\"const\": \"" + t.name + "\""), std::string::npos);
  // The committed schema is the generated one (regenerate with `btfsim schema -o
  // docs/scene.schema.json`).
  EXPECT_EQ(test::readFile(std::filesystem::path(test::sourceDir()) / "docs" / "scene.schema.json"),
            schema);
  // The reference part of docs/scene-format.md is the generated one (`btfsim scene-doc`).
  const std::string doc =
      test::readFile(std::filesystem::path(test::sourceDir()) / "docs" / "scene-format.md");
  EXPECT_NE(doc.find(sceneParamsMarkdown()), std::string::npos)
      << "regenerate the reference of docs/scene-format.md";
}

}  // namespace
}  // namespace btf
