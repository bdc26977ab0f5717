// Helpers shared by the engine tests: scenes from inline JSON, temp folders, running btfsim.
#pragma once
#include <btf/scene/scene.h>

#include <filesystem>
#include <string>

namespace btf::test {

/// A scene parsed from JSON text; relative paths resolve against `dir` (default: resources/).
Scene sceneFromJson(const std::string& json, const std::filesystem::path& dir = {});
/// A fresh empty folder under the build's temp area, removed at process exit is not needed.
std::filesystem::path tempDir(const std::string& name);
/// Runs btfsim with arguments; returns the exit code and captures stdout+stderr.
int runBtfsim(const std::string& args, std::string* output, const std::string& env = "");
std::string sourceDir();
std::string readFile(const std::filesystem::path& p);

}  // namespace btf::test
