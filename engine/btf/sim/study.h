// Accuracy versus time: sweeps the simulator's knobs (direction resolution, spp, shadow mode,
// network density, N1, links, path length) on one scene and measures each configuration's wall
// time and its error against the path-traced reference — the relative RMSE of the texel-averaged
// aBRDF over a fixed probe set of direction pairs (the BTF interpolated at the probe directions,
// so direction discretisation counts), and the per-texel relative RMSE of a few full images.
#pragma once
#include <btf/core/comm.h>
#include <btf/scene/scene.h>
#include <btf/sim/brdf_probe.h>
#include <btf/sim/direct.h>

#include <string>
#include <vector>

namespace btf {

struct StudyConfig {
  std::string method = "network";  // network | pt (path traced BTF, `paths` per sample)
  std::string dirs = "bonn81";
  int spp = 1;  // 0 = adaptive sampling (the simulator's default), K > 0 = uniform K×K
  ShadowMode shadows = ShadowMode::Map;
  int voxels = 0;  // 0 = one per texel
  int gather = 4;
  int links = 16;
  int bounces = 3;  // P; 1 = direct only; 0 = the planner's (as simulate by default)
  int paths = 1;    // pt only
  std::string label() const;
};

struct StudyResult {
  StudyConfig config;
  double seconds = 0, precomputeSeconds = 0, renderSeconds = 0;
  double probeRelRmse = 0;  // texel-averaged aBRDF interpolated at the probes vs the reference
  double setRelRmse = 0;    // the same at the probes snapped to the set's own directions (no
                            // interpolation: the simulation's error alone)
  double probeMaxRel = 0;   // worst probe, relative to its own reference value (|ref| > 1e-3)
  double imageRelRmse = 0;  // per-texel images vs the reference images
  size_t networkPoints = 0;
  uint64_t peakRssBytes = 0;
  /// The direct light's visibility the run took (SimulationJob::visibilityName): spp 0 on a
  /// faceted scene runs exact by area, not adaptive.
  std::string visibility = "sampled";
  /// config.label(), with " (exact)" / " (exact+sampled)" when the visibility was exact.
  std::string label() const {
    return visibility == "sampled" ? config.label() : config.label() + " (" + visibility + ")";
  }
  std::vector<Rgb> probeValues;  // the configuration's texel-averaged aBRDF at each probe
  std::vector<Rgb> setValues, setReference;  // at the snapped probes, and their reference
  bool pareto = false;
};

struct StudyOptions {
  int nu = 32, nv = 32;
  StudyConfig base;
  // Values swept for each knob (empty = only the base value).
  std::vector<std::string> methods, dirs;
  std::vector<int> spp, voxels, gather, links, bounces, paths;
  std::vector<ShadowMode> shadows;
  bool grid = false;           // false: one knob at a time around the base; true: the full product
  int referenceSamples = 256;  // per axis, per probe pair (n² paths)
  int imageSpp = 4, imagePaths = 8;
  uint64_t seed = 1;
  bool progress = true;
  const CancelToken* cancel = nullptr;  // checked between configurations
  /// A cluster job (docs/cluster.md): configuration i runs on rank i mod N (each rank computes
  /// the reference itself); rank 0 gets every result, the other ranks none.
  Comm* comm = nullptr;
};

struct Study {
  std::string scene;
  int nu = 0, nv = 0;
  std::vector<DirectionPair> probes;
  std::vector<Rgb> reference;
  std::vector<int> imageProbes;  // indices into probes that also get full images
  double referenceSeconds = 0;
  std::vector<StudyResult> results;
};

/// The fixed probe set: θi ∈ {0, 25, 50, 70}°, φi = 0, θo ∈ {0, 30, 60}°, φo ∈ {0, 90, 180}°.
std::vector<DirectionPair> studyProbePairs();

/// The configurations a sweep runs (the base first).
std::vector<StudyConfig> studyConfigs(const StudyOptions& o);

Study runStudy(const Scene& scene, const StudyOptions& o);

/// Marks the Pareto front (no other result is both faster and more accurate).
void markPareto(std::vector<StudyResult>& results);

/// study.csv, probes.csv (every probe value), study.md and study.svg (error vs time, log-log,
/// Pareto front joined) in `dir`.
void writeStudy(const Study& s, const std::string& dir);

/// One row of a study.csv as the studio plots it.
struct StudyRow {
  std::string config, dirs;
  int spp = 0;
  double seconds = 0, error = 0;  // wall time, probe relative RMSE: finite, >= 0
  bool pareto = false;
};
/// Reads the text of a study.csv (writeStudy's columns, found by name in the header line).
/// Throws btf::Error "SOURCE:LINE: …" naming the column and the rule for a missing column, a
/// short row or a value that is not a finite number >= 0; at most 100 000 rows.
std::vector<StudyRow> parseStudyCsv(const std::string& text, const std::string& source);

}  // namespace btf
