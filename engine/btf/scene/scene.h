// The scene: a periodic tile, named materials and parts, default simulation settings.
// Read from and written to the versioned JSON scene file (docs/scene-format.md).
#pragma once
#include <btf/scene/params.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace btf {

inline constexpr int kSceneVersion = 1;

struct MaterialDef {
  std::string name;
  std::string type;
  ParamSet params;
  bool operator==(const MaterialDef&) const = default;
};

struct PartDef {
  std::string name;
  std::string type;
  std::string material;
  ParamSet params;
  ParamSet transform;
  ParamSet array;
  bool operator==(const PartDef&) const = default;
};

struct Scene {
  std::string name;
  double Lx = 1, Ly = 1;
  std::vector<MaterialDef> materials;
  std::vector<PartDef> parts;
  ParamSet simulation;
  std::filesystem::path baseDir;  // folder that relative paths are resolved against
  std::string source;             // file name used in error messages
  int materialIndex(const std::string& name) const;
  bool operator==(const Scene& o) const {
    return name == o.name && Lx == o.Lx && Ly == o.Ly && materials == o.materials &&
           parts == o.parts && simulation == o.simulation;
  }
};

/// Parses a scene from JSON text; `source` names the file in messages and `baseDir` resolves
/// relative paths. Throws btf::Error naming source, line (for syntax) or JSON path, and rule.
Scene parseScene(const std::string& text, const std::string& source,
                 const std::filesystem::path& baseDir);
/// Scene files larger than this are refused before they are read.
constexpr uint64_t kMaxSceneFileBytes = uint64_t(64) << 20;
Scene loadScene(const std::filesystem::path& path);
/// Canonical JSON of the scene, every parameter written (defaults included).
std::string sceneToJson(const Scene& scene);
/// JSON Schema (draft 2020-12) of the scene file, generated from the declarations.
std::string sceneJsonSchema();
/// Markdown reference of every declared type and parameter (docs/scene-format.md).
std::string sceneParamsMarkdown();
/// Resolves a path parameter against the scene's folder.
std::filesystem::path resolvePath(const Scene& scene, const std::string& p);

}  // namespace btf
