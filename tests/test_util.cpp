#include "test_util.h"

#include <btf/core/error.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

namespace btf::test {

std::string sourceDir() {
  return BTF_SOURCE_DIR;
}

Scene sceneFromJson(const std::string& json, const std::filesystem::path& dir) {
  return parseScene(json, "test.json",
                    dir.empty() ? std::filesystem::path(sourceDir()) / "resources" : dir);
}

namespace {

// The test's temporary folders, removed when its process ends after every test passed (a
// failure keeps them for a look, as does BTF_KEEP_TEST_FILES=1): ctest runs each test in a
// process of its own, and a full run used to leave ~0.7 GiB in the temporary folder.
struct TempDirs {
  pid_t owner = ::getpid();
  std::vector<std::filesystem::path> paths;
  ~TempDirs() {
    if (::getpid() != owner || std::getenv("BTF_KEEP_TEST_FILES")) return;  // a forked child
    const ::testing::UnitTest* u = ::testing::UnitTest::GetInstance();
    if (u && !u->Passed()) return;
    std::error_code ec;
    for (const auto& p : paths) std::filesystem::remove_all(p, ec);
  }
};

TempDirs& tempDirs() {
  static TempDirs t;
  return t;
}

}  // namespace

std::filesystem::path tempDir(const std::string& name) {
  auto p = std::filesystem::temp_directory_path() /
           ("btf_test_" + std::to_string(::getpid()) + "_" + name);
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  tempDirs().paths.push_back(p);
  return p;
}

int runBtfsim(const std::string& args, std::string* output, const std::string& env) {
  const std::string cmd =
      env + (env.empty() ? "" : " ") + BTF_BTFSIM + std::string(" ") + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return -1;
  std::array<char, 4096> buf;
  std::string out;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  const int status = pclose(p);
  if (output) *output = out;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string readFile(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

void addDegenerateTriangles(TileGeometry& g) {
  const uint32_t b = uint32_t(g.mesh.pos.size());
  for (Vec3 p : {Vec3(0.2f, 0.2f, 0.3f), Vec3(0.8f, 0.8f, 0.3f), Vec3(0.5f, 0.5f, 0.3f)}) {
    g.mesh.pos.push_back(p);
    g.mesh.nrm.push_back(Vec3(0, 0, 1));
  }
  g.mesh.tri.push_back({b, b, b + 1});
  g.mesh.tri.push_back({b, b + 1, b + 2});
  g.triMaterial.resize(g.mesh.tri.size(), 0);
  g.triPart.resize(g.mesh.tri.size(), 0);
}

std::string errorOf(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace btf::test
