// btfsim's commands, callable without the argument parser (the tests call them too).
// Each returns the process exit code; errors are thrown as btf::Error and reported by main.
#pragma once
#include <string>
#include <vector>

namespace btf::cli {

/// Effect plan, method and point-network options shared by simulate, plan, bench and study.
struct EffectArgs {
  std::string method;  // network | pt; empty = the scene's simulation.method
  std::string selfShadowing = "auto", interreflection, colour = "auto", vmf = "auto";  // "" = scene
  std::string glossyIndirect = "auto";
  int bounces = 0;  // 0 = from the plan
  double epsilon = 0.01;
  int networkVoxels = 0, links = 16, gather = 4, paths = 16;
};

/// Codec options shared by simulate --compress, compress and study.
struct CodecArgs {
  std::string codec = "nmf", colourModel = "ycc", betaMode = "energy", solver = "hals";
  int components = 0, maxRank = 8, iterations = 60, trainTexels = 256, clusters = 8;
  double beta = 0.995, targetRmse = 0, targetRatio = 0;
  bool f32 = false;
};

struct SimulateArgs {
  std::string scene, output;
  EffectArgs effects;
  std::string compress;  // codec name: compress while simulating, output is a .cbtf
  CodecArgs codec;
  std::string dirs, texels, shadows, memoryBudget = "4G";
  int spp = 0, threads = 0, chunkTexels = 0;
  long long seed = -1;
  double bias = 1.0;
  bool resume = false, json = false, quiet = false;
};
int simulate(const SimulateArgs& a);

struct CompressArgs {
  std::string input, output;
  CodecArgs codec;
  int threads = 0;
  std::string memoryBudget = "8G";
  bool compare = false, json = false, quiet = false;
};
int compress(const CompressArgs& a);

struct CompareArgs {
  std::string a, b, maps;
  int worst = 10, threads = 0;
  bool json = false, quiet = false;
};
int compare(const CompareArgs& a);

struct ExportArgs {
  std::string input, format, output;
  int components = 16, phiSamples = 16, threads = 0;
  bool quiet = false;
};
int exportBtf(const ExportArgs& a);

struct BrdfArgs {
  std::string scene;
  std::string method = "pt";       // pt (every effect) | direct (direct light and self-shadowing)
  int bounces = 0;                 // pt: reflections per path, 0 = unbounded (Russian roulette)
  int paths = 1;                   // pt: paths per sample position
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
  EffectArgs effects;
  std::string texels = "64", dirs = "16x32", shadows = "map,rays";
  int spp = 1, threads = 0, repeat = 3;
  bool json = false;
};
int bench(const BenchArgs& a);

struct PlanArgs {
  std::string scene, dirs, texels, shadows;
  int spp = 0, threads = 0;
  EffectArgs effects;
  bool json = false;
};
int plan(const PlanArgs& a);

struct StudyArgs {
  std::string scene, output, texels = "32";
  // Comma-separated values per knob; the first value of each is the base configuration.
  std::string methods = "network", paths = "1";
  std::string dirs = "bonn81,8x16,16x32", spp = "1,2", shadows = "map,rays", voxels = "0,16,64",
              gather = "4,1,8", links = "16,8,32", bounces = "3,1,2,4";
  bool grid = false;
  int referenceSpp = 256, threads = 0;
  bool quiet = false;
  // Compression knobs: with --codecs, the base configuration's BTF is simulated once and
  // compressed with every codec × β (nmf) × components; compression.csv/md report the rows.
  std::string codecs, betas = "0.995", components = "0";
  CodecArgs codec;
};
int study(const StudyArgs& a);

int schema(const std::string& output);
int sceneDoc(const std::string& output);

}  // namespace btf::cli
namespace btf {
struct SimOptions;
struct Scene;
}  // namespace btf
namespace btf::cli {
/// The scene's simulation defaults with the common options applied (empty / 0 = keep).
SimOptions sceneOptions(const Scene& scene, const std::string& texels, const std::string& dirs,
                        int spp, const std::string& shadows);
/// Applies the effect/method/network options to simulation options (validates them).
void applyEffects(const EffectArgs& e, SimOptions* o);

/// "64" → (64, 64); "64x32" → (64, 32). Throws btf::Error naming the text.
void parseTexels(const std::string& s, int* nu, int* nv);
/// "30,45" → (30, 45). Throws btf::Error naming `what` and the text.
void parseAnglePair(const std::string& s, const std::string& what, double* theta, double* phi);

}  // namespace btf::cli
