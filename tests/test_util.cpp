#include "test_util.h"

#include <btf/core/error.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace btf::test {

std::string sourceDir() {
  return BTF_SOURCE_DIR;
}

Scene sceneFromJson(const std::string& json, const std::filesystem::path& dir) {
  return parseScene(json, "test.json",
                    dir.empty() ? std::filesystem::path(sourceDir()) / "resources" : dir);
}

std::filesystem::path tempDir(const std::string& name) {
  auto p = std::filesystem::temp_directory_path() /
           ("btf_test_" + std::to_string(::getpid()) + "_" + name);
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
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
