// A simulation job: scene → geometry → periodic tracer → hit maps → direct illumination →
// chunks of the raw BTF store. Memory is bounded by the budget (the chunk size follows from it),
// the estimate of time, memory and disk comes before any work, and runs resume chunk by chunk.
#pragma once
#include <btf/directions/direction_set.h>
#include <btf/geometry/mesh.h>
#include <btf/scene/material.h>
#include <btf/scene/scene.h>
#include <btf/sim/direct.h>
#include <btf/store/btf_store.h>
#include <btf/trace/periodic_tracer.h>

#include <memory>
#include <string>

namespace btf {

struct SimOptions {
  int nu = 32, nv = 32;
  std::string directions = "bonn81";
  int spp = 1;
  ShadowMode shadows = ShadowMode::Map;
  float shadowBias = 1.0f;
  uint64_t seed = 1;
  uint64_t memoryBudget = uint64_t(4) << 30;
  uint64_t maxChunkBytes = uint64_t(256) << 20;  // resume granularity
  bool resume = false;
  bool progress = true;
};

/// Options from the scene's "simulation" block (the command line overrides them afterwards).
SimOptions optionsFromScene(const Scene& scene);

struct SimEstimate {
  double seconds = 0, hitMapSeconds = 0, evalSeconds = 0;
  uint64_t memoryBytes = 0, hitMapBytes = 0, chunkBytes = 0, diskBytes = 0, freeDiskBytes = 0;
  int chunkTexels = 1, chunks = 1;
  int threads = 1;
  std::string refusal;  // non-empty when the job cannot run within budget or disk
};

struct SimReport {
  std::string output;
  double wallSeconds = 0, hitMapSeconds = 0, evalSeconds = 0, writeSeconds = 0;
  uint64_t hitMapRays = 0;
  uint64_t abrdfValues = 0;      // (texel, view, light) values computed
  uint64_t brdfEvaluations = 0;  // (sample, view, light) BRDF × visibility evaluations
  uint64_t peakRssBytes = 0, outputBytes = 0;
  int chunks = 0, chunksResumed = 0;
  bool cancelled = false;
};

class SimulationJob {
 public:
  SimulationJob(const Scene& scene, SimOptions options);
  ~SimulationJob();

  const Scene& scene() const { return m_scene; }
  const SimOptions& options() const { return m_opt; }
  const TileGeometry& geometry() const { return m_geom; }
  const PeriodicTracer& tracer() const { return *m_tracer; }
  const DirectionSet& directions() const { return m_dirs; }
  const std::vector<Material>& materials() const { return m_materials; }
  std::string sceneHash() const;
  /// The store header this job writes (chunk size from the memory budget).
  BtfInfo storeInfo(int chunkTexels) const;

  /// Memory and disk from the layout; time from a calibration run on this scene and machine.
  SimEstimate estimate(const std::string& outPath) const;
  /// Runs the job into `outPath` (atomic; resumable). With an empty path, computes every chunk
  /// and discards it (benchmarks).
  SimReport run(const std::string& outPath, const SimEstimate& est,
                const CancelToken* cancel = nullptr);

 private:
  Scene m_scene;
  SimOptions m_opt;
  TileGeometry m_geom;
  std::unique_ptr<PeriodicTracer> m_tracer;
  DirectionSet m_dirs;
  std::vector<Material> m_materials;
};

}  // namespace btf
