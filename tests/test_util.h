// Helpers shared by the engine tests: scenes from inline JSON, temp folders, running btfsim.
#pragma once
#include <btf/geometry/mesh.h>
#include <btf/scene/scene.h>

#include <filesystem>
#include <functional>
#include <string>

namespace btf::test {

/// A scene parsed from JSON text; relative paths resolve against `dir` (default: resources/).
Scene sceneFromJson(const std::string& json, const std::filesystem::path& dir = {});
/// A fresh empty folder under the build's temp area, removed at process exit is not needed.
std::filesystem::path tempDir(const std::string& name);
/// Runs btfsim with arguments; returns the exit code and captures stdout+stderr.
int runBtfsim(const std::string& args, std::string* output, const std::string& env = "");
std::string sourceDir();
/// Appends a zero-area triangle (repeated vertex) and a collinear sliver across the tile, with
/// material and part 0: the degenerate-geometry hard case.
void addDegenerateTriangles(TileGeometry& g);
std::string readFile(const std::filesystem::path& p);
/// The btf::Error message `fn` throws, "" when it throws none.
std::string errorOf(const std::function<void()>& fn);

}  // namespace btf::test
