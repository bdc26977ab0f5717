// btfsim's commands, callable without the argument parser (the tests call them too).
// Each returns the process exit code; errors are thrown as btf::Error and reported by main.
#pragma once
#include <string>
#include <vector>

namespace btf::cli {

struct SimulateArgs {
  std::string scene, output;
  std::string dirs, texels, shadows, memoryBudget = "4G";
  int spp = 0, threads = 0;
  long long seed = -1;
  double bias = 1.0;
  bool resume = false, json = false, quiet = false;
};
int simulate(const SimulateArgs& a);

struct BrdfArgs {
  std::string scene;
  std::vector<std::string> pairs;  // "θi,φi,θo,φo" in degrees
  std::string pairsFile;           // CSV of the same
  int samples = 64;                // samples per axis over the tile
  int threads = 0;
  bool json = false;
};
int brdf(const BrdfArgs& a);

struct SliceArgs {
  std::string btf, output, view, light, texel;
  float exposure = 1.0f;
  int size = 256;
};
int slice(const SliceArgs& a);

struct InfoArgs {
  std::string btf;
  bool json = false;
};
int info(const InfoArgs& a);

struct BenchArgs {
  std::string scene;
  std::string texels = "64", dirs = "16x32", shadows = "map,rays";
  int spp = 1, threads = 0, repeat = 3;
  bool json = false;
};
int bench(const BenchArgs& a);

int schema(const std::string& output);
int sceneDoc(const std::string& output);

/// "64" → (64, 64); "64x32" → (64, 32). Throws btf::Error naming the text.
void parseTexels(const std::string& s, int* nu, int* nv);
/// "30,45" → (30, 45). Throws btf::Error naming `what` and the text.
void parseAnglePair(const std::string& s, const std::string& what, double* theta, double* phi);

}  // namespace btf::cli
