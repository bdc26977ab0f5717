// A simulation job: scene → geometry → periodic tracer → hit maps → direct illumination →
// chunks of the raw BTF store. Memory is bounded by the budget (the chunk size follows from it),
// the estimate of time, memory and disk comes before any work, and runs resume chunk by chunk.
#pragma once
#include <btf/core/comm.h>
#include <btf/core/run_context.h>
#include <btf/directions/direction_set.h>
#include <btf/geometry/mesh.h>
#include <btf/scene/material.h>
#include <btf/scene/scene.h>
#include <btf/sim/adaptive.h>
#include <btf/sim/direct.h>
#include <btf/sim/exact_direct.h>
#include <btf/sim/network.h>
#include <btf/sim/planner.h>
#include <btf/store/btf_store.h>
#include <btf/trace/periodic_tracer.h>

#include <functional>
#include <memory>
#include <string>

namespace btf {

inline NetworkSettings autoNetwork() {
  NetworkSettings n;
  n.voxels = 0;
  return n;
}

struct SimOptions {
  int nu = 32, nv = 32;
  std::string directions = "bonn81";
  int spp = 1;  // uniform sampling: K×K jittered samples per texel (1 = texel centre)
  /// Adaptive integration of each texel's footprint (sim/adaptive.h), the default; uniform K×K
  /// (`spp`) is the reference mode. The path tracer (method pt) always samples uniformly.
  /// Off in a bare SimOptions; optionsFromScene takes the scene's `sampling` (adaptive unless
  /// the scene says uniform), so every command and the studio default to adaptive.
  bool adaptive = false;
  AdaptiveSettings adaptiveSettings;
  ShadowMode shadows = ShadowMode::Map;
  float shadowBias = 1.0f;
  /// Map mode: lights at θi ≥ this (degrees) use exact shadow rays (90 = none): the planner's
  /// grazing_rays decision.
  double grazingRays = 70;
  bool grazingRaysForced = false;  // given by the user rather than the default
  uint64_t seed = 1;
  uint64_t memoryBudget = uint64_t(4) << 30;
  uint64_t maxChunkBytes = uint64_t(256) << 20;  // resume granularity
  int maxChunkTexels = 0;                        // > 0: at most this many texels per chunk
  bool resume = false;
  bool progress = true;
  /// "network": direct light plus the point network's inter-reflection where the plan calls for
  /// it; "pt": unbiased path tracing of every value (small configurations, the reference).
  std::string method = "network";
  PlanRequest plan;
  NetworkSettings network = autoNetwork();  // voxels 0: one voxel per texel, in [64, 128]
  int ptPaths = 16;                         // --method pt: paths per texel sample
  /// The network's gathered light scaled per (view, light) so that its tile average is
  /// reciprocal (sim/reciprocal_gather.h).
  bool reciprocalGather = true;
  /// Direct light's visibility: "exact" (sim/exact_direct.h: flat faces by area, smooth faces
  /// sampled uniformly on the hit maps), "sampled" (adaptive or uniform samples), "auto" (exact
  /// when adaptive sampling is asked for and every face is flat; sampled otherwise).
  std::string visibility = "auto";
};

/// Options from the scene's "simulation" block (the command line overrides them afterwards).
SimOptions optionsFromScene(const Scene& scene);

struct SimEstimate {
  double seconds = 0, hitMapSeconds = 0, evalSeconds = 0;
  double networkSeconds = 0, lightSeconds = 0, gatherSeconds = 0;  // parts of the above
  double exactSeconds = 0;  // exact visibility's share of evalSeconds
  double reciprocalSeconds = 0;  // the reciprocal gather's tile sums' share of evalSeconds
  uint64_t memoryBytes = 0, hitMapBytes = 0, chunkBytes = 0, diskBytes = 0, freeDiskBytes = 0;
  uint64_t networkBytes = 0;
  int chunkTexels = 1, chunks = 1;
  int threads = 1;
  std::string refusal;  // non-empty when the job cannot run within budget or disk
};

struct SimReport {
  std::string output;
  double wallSeconds = 0, hitMapSeconds = 0, evalSeconds = 0, writeSeconds = 0;
  // Table 4.I's split: precompute = network (sampling, α, links) + hit maps; render = per-light
  // network solve + every texel's values.
  double networkSeconds = 0, lightSeconds = 0, precomputeSeconds = 0, renderSeconds = 0;
  size_t networkPoints = 0, networkLinks = 0;
  bool networkReused = false;  // the network was built by an earlier job of this process
  uint64_t hitMapRays = 0;
  uint64_t abrdfValues = 0;      // (texel, view, light) values computed
  uint64_t brdfEvaluations = 0;  // (sample, view, light) BRDF × visibility evaluations
  uint64_t peakRssBytes = 0, outputBytes = 0;
  int chunks = 0, chunksResumed = 0;
  std::string resumeNote;
  // Adaptive sampling: samples per value (histogram), the error estimate (JSON of AdaptiveStats)
  bool adaptive = false;
  std::string samplingJson, samplingText;
  double meanSamples = 0, estimatedError = 0;
  // Exact visibility (empty when sampled): "exact" (every face flat) or "exact+sampled" (smooth
  // faces sampled); the hidden-surface removal's time.
  std::string visibility = "sampled";
  double exactSeconds = 0;
  // The reciprocal gather: the time of its tile sums and the largest correction it applied.
  double reciprocalSeconds = 0, reciprocalMaxCorrection = 0;
  // A cluster job (docs/cluster.md): ranks, the chunks and texels this rank computed, and the
  // bytes it sent and received through the communicator.
  int ranks = 1, chunksComputed = 0;
  double texelsComputed = 0;  // texels × views computed / views (a split chunk's share)
  double rankEvalSeconds = 0;  // this rank's aBRDF time (its chunks), before the final agreement
  uint64_t commBytes = 0;      // the chunks' traffic, the GI share apart
  // The network's light solve: lights this rank solved (every R-th one in a cluster job); the
  // bytes of sharing the ranks' light solutions and reciprocal-gather tile sums; the seconds of
  // sharing the light solutions.
  int lightsSolved = 0;
  uint64_t giShareBytes = 0;
  double lightShareSeconds = 0;
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
  /// Adaptive sampling in effect (network method and not --sampling uniform).
  bool adaptive() const { return m_adaptive; }
  /// Exact direct light in effect (--visibility, or auto on a faceted scene): null when sampled.
  const ExactDirect* exactDirect() const { return m_exact.get(); }
  /// "exact", "exact+sampled" (smooth faces sampled) or "sampled".
  std::string visibilityName() const;
  /// Samples per texel side of the hit maps: spp when uniform; 4 (or 2 when the memory budget
  /// is tight, or --max-spp 2) when adaptive.
  int mapSpp() const { return m_mapSpp; }
  /// Cancellation of the set-up work (the point network, the planner's probes, the estimate's
  /// calibration): each throws btf::Cancelled once `cancel` is set. run() takes its own.
  void setCancel(const CancelToken* cancel) { m_cancel = cancel; }
  /// The processes run() spreads its chunks over (docs/cluster.md); null = this one. Every rank
  /// builds the same job and calls run() with the same path: rank 0 creates (or resumes) the
  /// partial and finishes it, each rank computes its share of the missing chunks and writes them
  /// into it; the sinks see only this rank's chunks. The file is the one a single process writes.
  void setComm(Comm* comm) { m_comm = comm; }
  /// The effect plan (computed on first use: builds the point network unless inter-reflection is
  /// forced off).
  const EffectPlan& plan() const;
  /// The point network (null when none was built).
  const PointNetwork* network() const;
  /// How glossy receivers gather indirect light (from the materials and the memory budget).
  GlossyGather glossyGather() const;
  /// Network settings after resolving the automatic density.
  NetworkSettings networkSettings() const;
  /// Chunk consumer: receives every finished chunk (texels [t0, t1), texel-major values).
  using ChunkSink = std::function<void(int chunk, int64_t t0, int64_t t1, const float* values)>;
  void setChunkSink(ChunkSink sink) { m_sink = std::move(sink); }
  /// Visibility-map consumer (on every rank, after the hit maps and before the training
  /// texels, when the plan keeps the map):
  /// nDirs × texels × (coverage, mean depth), what a store would hold — a streamed .cbtf's.
  using VmfSink = std::function<void(std::vector<float> vmf)>;
  void setVmfSink(VmfSink sink) { m_vmfSink = std::move(sink); }
  /// Texels computed once before the chunks (a compressor's training subset): their values,
  /// texel-major in the given order, go to `sink` after the set-up and before chunk 0.
  using TrainingSink = std::function<void(const float* values)>;
  void setTrainingTexels(std::vector<int64_t> texels, TrainingSink sink) {
    m_trainTexels = std::move(texels);
    m_trainSink = std::move(sink);
  }
  /// The aBRDF image of one (view, light) pair over an nu × nv texel grid (row-major, RGB),
  /// computed exactly as run() computes that pair (same samples, shadow maps and, when
  /// `indirect` and the plan asks for it, the network's inter-reflection): the studio's live
  /// preview. Directions from the job's set give the values `btfsim slice` reads from the store.
  std::vector<float> renderPair(const Direction& view, const Direction& light, int nu, int nv,
                                bool indirect, const CancelToken* cancel = nullptr) const;
  /// Every value (views × lights × RGB, texel-major in the given order) of a few texels, as run()
  /// computes them: the studio's texel BRDF view. Every
  /// stage throws btf::Cancelled once `cancel` is set (run() leaves the .partial for --resume).
  std::vector<float> evaluateTexels(const std::vector<int64_t>& texels,
                                    const CancelToken* cancel = nullptr);
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
  mutable std::unique_ptr<EffectPlan> m_plan;
  mutable std::shared_ptr<const PointNetwork> m_network;  // sim/network_cache.h
  mutable bool m_networkReused = false;
  ChunkSink m_sink;
  VmfSink m_vmfSink;
  std::vector<int64_t> m_trainTexels;
  TrainingSink m_trainSink;
  bool m_onlyTrainingTexels = false;
  const CancelToken* m_cancel = nullptr;
  Comm* m_comm = nullptr;
  bool m_adaptive = false;
  int m_mapSpp = 1;
  std::unique_ptr<ExactDirect> m_exact;  // prepared by run() (and the estimate's calibration)
  void checkCancel() const;
};

}  // namespace btf
