// The typed reports of the use cases: one struct per command with the fields its schema in
// docs/schemas/COMMAND.json describes, in the order `--json` prints them. A use case fills its
// struct; reports.cpp serialises it (the CLI's --json, the studio's report file); the studio,
// the tests and the Python package read the fields, not strings. The blocks whose keys depend on
// the codec or the sampler (a codec's params and stats, the adaptive sampler's statistics) stay
// JSON objects: their schema is the codec's own (docs/compression.md).
#pragma once
#include <btf/compress/compress.h>
#include <btf/render/renderer.h>

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace btf::ops {

using Json = nlohmann::ordered_json;

// ----- pieces several reports share

/// A cluster job's balance and traffic (docs/cluster.md), one entry per rank.
struct ClusterFigures {
  struct Rank {
    double texels = 0, dataBytes = 0, communicatedBytes = 0, communicatedFraction = 0, seconds = 0;
    // A simulation with inter-reflection: the network's lights this rank solved and the bytes of
    // sharing every rank's light solutions and reciprocal-gather tile sums (apart from
    // communicatedBytes, which is the chunks' traffic).
    double lightsSolved = 0, giShareBytes = 0;
  };
  int ranks = 1;
  std::string communicator;
  double maxCommunicatedBytes = 0, maxCommunicatedFraction = 0, balance = 1;
  std::vector<Rank> perRank;
};

/// One texel level of a pyramid and its error against the box-filtered input.
struct LevelFigures {
  int level = 0, nu = 0, nv = 0;
  double relRmse = 0, rmse = 0;
};

/// The bytes, times and ratio of a compressed file (compress, simulate --compress).
struct CodecFigures {
  Json params = Json::object(), stats = Json::object();  // the codec's own (its schema)
  double rawBytes = 0;
  uint64_t compressedBytes = 0;
  uint64_t vmfBytes = 0;  // of compressedBytes: the visibility map the file carries
  double ratio = 0;
  uint64_t peakMemoryBytes = 0;
};

// ----- one struct per command

struct SimulateResult {
  std::string output, scene;
  int nu = 0, nv = 0;
  std::string directions;
  int directionCount = 0, spp = 0;
  std::string sampling, shadows, method;
  std::string visibility = "sampled";  // "exact", "exact+sampled" or "sampled"
  Json plan = Json::object();  // EffectPlan::toJson
  int threads = 1;
  double estimatedSeconds = 0;
  std::optional<ClusterFigures> cluster;
  /// The adaptive sampler's statistics (AdaptiveStats' JSON); absent for uniform sampling.
  std::optional<Json> samples;
  /// A raw store was written.
  struct Store {
    size_t networkPoints = 0, networkLinks = 0;
    double precomputeSeconds = 0, renderSeconds = 0, networkSeconds = 0, networkLightSeconds = 0;
    double wallSeconds = 0, hitMapSeconds = 0, abrdfSeconds = 0, writeSeconds = 0;
    uint64_t hitMapRays = 0;
    double raysPerSecond = 0;
    uint64_t abrdfValues = 0;
    double abrdfEvaluationsPerSecond = 0;
    uint64_t brdfEvaluations = 0, peakMemoryBytes = 0, outputBytes = 0;
    int chunks = 0, chunksResumed = 0;
    double exactVisibilitySeconds = 0;  // the exact mode's hidden-surface removal (in wall)
    // The reciprocal gather's tile sums (in wall) and the largest per-pair correction it made.
    double reciprocalGatherSeconds = 0, reciprocalGatherMaxCorrection = 0;
    bool networkReused = false;  // built by an earlier job of this process (network_seconds 0)
  };
  /// --compress: the values went straight into a codec (with --mip: a pyramid).
  struct Compressed {
    CodecFigures file;
    double wallSeconds = 0, simulateSeconds = 0;
    std::optional<double> levelSeconds;  // --mip
    double encodeSeconds = 0, finishSeconds = 0;
    std::vector<LevelFigures> levels;  // --mip
  };
  std::optional<Store> store;
  std::optional<Compressed> compressed;
};

struct CompressResult {
  std::optional<ClusterFigures> cluster;
  std::string input, output;
  CodecFigures file;
  double seconds = 0, trainSeconds = 0, encodeSeconds = 0, finishSeconds = 0;
  /// --mip: the pyramid's figures.
  struct Pyramid {
    double levelSeconds = 0, rawBytes = 0, ratio = 0;
    std::vector<LevelFigures> levels;
  };
  std::optional<Pyramid> pyramid;
  /// --compare: the full comparison of the file against its input.
  std::optional<ErrorReport> error;
};

struct CompareResult {
  ErrorReport error;
  int level = 0;
  struct Side {
    std::string path, kind;
    double ratio = 1;
  };
  Side a, b;
  std::string maps;  // empty: none written
  /// Non-empty when A and B have different direction sets: B was evaluated at A's directions,
  /// "continuous" (its codec's own decode) or "interpolated" (between its set directions).
  std::string bAtADirections;
  /// --noise: A's own noise floor and B's error in excess of it.
  struct Noise {
    std::string path;
    double floorRmse = 0, floorRelRmse = 0, excessRelRmse = 0;
  };
  std::optional<Noise> noise;
};

// The details of each export format (ExportResult::details).
struct ExportUbo2003 {
  int64_t images = 0;
  std::string imageFormat;
  bool zip = false;
  std::optional<double> scale, clippedFraction;  // 8-bit formats
};
struct ExportUbo2014 {
  uint64_t bytes = 0;
  std::array<int, 3> components{};
  double factorisationRelRmse = 0, exportRelRmse = 0;
};
struct ExportRgl {
  uint64_t bytes = 0;
  int thetaI = 0, phiI = 0, resolution = 0;
  double ndfProjectedArea = 0;
};
struct ExportMerl {
  int64_t bins = 0, missingBins = 0;
  double anisotropy = 0, asymmetry = 0, asymmetryMax = 0;
};

struct ExportResult {
  std::string input, format, output;
  int level = 0;
  using Ubo2003 = ExportUbo2003;
  using Ubo2014 = ExportUbo2014;
  using Merl = ExportMerl;
  using Rgl = ExportRgl;
  std::variant<Ubo2003, Ubo2014, Merl, Rgl> details;
};

struct PlanResult {
  Json plan = Json::object();  // EffectPlan::toJson, at the top level of the report
  std::string scene, method;
  int nu = 0, nv = 0;
  std::string directions;
  size_t triangles = 0;
  struct Estimate {
    double seconds = 0, hitMapSeconds = 0, abrdfSeconds = 0, networkLightSeconds = 0,
           gatherSeconds = 0;
    uint64_t memoryBytes = 0, networkBytes = 0;
  } estimate;
  struct Network {
    size_t points = 0, links = 0;
    int voxels = 0;
    double buildSeconds = 0;
  };
  std::optional<Network> network;
};

struct BenchResult {
  struct Mode {
    std::string shadows, method;
    bool interreflection = false;
    int bounces = 0, nu = 0, nv = 0;
    std::string directions;
    int64_t pairs = 0;
    int spp = 0;
    std::string sampling;
    std::optional<Json> samples;
    int threads = 1, runs = 1;
    double medianWallSeconds = 0, medianHitMapSeconds = 0, medianAbrdfSeconds = 0,
           medianRaysPerSecond = 0, medianAbrdfValuesPerSecond = 0, estimatedSeconds = 0,
           peakRssBytes = 0;
    uint64_t memoryBudgetBytes = 0;
  };
  std::string scene;
  std::vector<Mode> results;
};

struct BrdfResult {
  std::string scene, method;
  int bounces = 0, samples = 0;
  struct Pair {
    double thetaI = 0, phiI = 0, thetaO = 0, phiO = 0;
    std::array<float, 3> abrdf{};
  };
  std::vector<Pair> pairs;
};

struct SliceResult {
  std::string input, output;
  std::array<double, 2> light{};
  int level = 0;
  std::string kind;              // "spatial" or "hemisphere"
  std::array<double, 2> view{};  // spatial
  std::string texel;             // hemisphere: "u,v" or "avg"
  int width = 0, height = 0;
};

// What info reads from each kind of file (InfoResult::details).
struct InfoCompressed {
  std::string codec, colour;
  Json params = Json::object(), stats = Json::object();
  double ratio = 0;
  struct Array {
    std::string name;
    int64_t rows = 0, cols = 0;
    std::string type;
  };
  std::vector<Array> arrays;
  struct Level {
    int nu = 0, nv = 0;
    int64_t first = 0;
    std::optional<double> relRmse;  // null when compress did not record it
  };
  std::vector<Level> levels;  // a pyramid's
  struct DecoderBench {
    double randomValuesPerSecond = 0, texelValuesPerSecond = 0, checksum = 0;
  };
  std::optional<DecoderBench> decoderBench;
};
struct InfoRaw {
  double Lx = 0, Ly = 0;
  int chunkTexels = 0, chunks = 0, spp = 0;
  std::string shadows;
  double shadowBias = 0;
  uint64_t seed = 0;
  Json plan;  // the stored plan (an object, or its text when it does not parse)
  bool hasVmf = false;
  std::vector<int> badChunks;
  bool vmfOk = true;
};

struct InfoResult {
  std::string path, format;  // format: "raw" or "compressed"
  std::string scene, sceneHash;
  int nu = 0, nv = 0;
  std::string directionSet;
  int directionCount = 0;
  std::vector<std::array<double, 2>> directionsDeg;
  uint64_t fileBytes = 0;
  bool verified = false;
  using Compressed = InfoCompressed;
  using Raw = InfoRaw;
  std::variant<Compressed, Raw> details;
};

struct RenderResult {
  std::string input, output, mode, object;
  int width = 0, height = 0, spp = 0;
  double tiling = 0, reliefScale = 0;
  std::string filter;
  struct TexelLevels {
    int count = 1;
    std::string from;  // "none", "file", "box filtered"
    int forced = -1, maxAniso = 0;
  };
  std::optional<TexelLevels> texelLevels;  // flat and mapped
  std::array<double, 2> camera{}, light{};
  double irradiance = 0, environment = 0;
  std::string projection;
  double worldPerTileUnit = 0;
  size_t prisms = 0, shellFaces = 0;
  std::array<double, 2> heightRangeWorld{};
  std::optional<double> mappedSpeedup;  // --mode all
  struct Image {
    std::string mode;
    double seconds = 0;
    uint64_t samples = 0, rays = 0, triangles = 0;
    struct Footprint {
      size_t pixels = 0;
      std::optional<float> medianTexelsPerSample;
      std::vector<double> levelShare;
    };
    std::optional<Footprint> footprint;  // flat and mapped
    std::string output;
    std::optional<ImageError> error;         // --reference
    std::optional<ImageError> errorVsExact;  // --mode all, mapped and flat
  };
  std::vector<Image> images;
};

struct StudyResult {
  std::string scene, output;
  struct Configuration {
    std::string config;
    double seconds = 0, probeRelRmse = 0, setRelRmse = 0, imageRelRmse = 0;
    bool pareto = false;
  };
  std::vector<Configuration> configurations;
  struct Codec {
    std::string codec;
    double beta = 0;
    int components = 0;
    double ratio = 0;
    uint64_t bytes = 0;
    double rmse = 0, relRmse = 0, psnrDb = 0, seconds = 0;
    bool pareto = false;
  };
  std::optional<std::vector<Codec>> compression;  // --codecs
  struct Pyramid {
    std::string codec;
    uint64_t bytes = 0;
    double sizeVsSingleLevel = 0, levelSeconds = 0, seconds = 0;
    struct Level {
      int nu = 0, nv = 0;
      double relRmse = 0;
    };
    std::vector<Level> levels;
  };
  std::optional<std::vector<Pyramid>> pyramid;  // --codecs --mip
};

/// What a use case returned (monostate: nothing yet, e.g. a cluster rank other than 0).
using Result = std::variant<std::monostate, SimulateResult, CompressResult, CompareResult,
                            ExportResult, PlanResult, BenchResult, BrdfResult, SliceResult,
                            InfoResult, RenderResult, StudyResult>;

/// The report's JSON, as `--json` prints it (without the request echo that run() adds).
Json toJson(const Result& r);
Json toJson(const ClusterFigures& c);
Json toJson(const ErrorReport& e);
Json toJson(const ImageError& e);

}  // namespace btf::ops
