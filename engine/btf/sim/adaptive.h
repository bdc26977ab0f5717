// Adaptive integration of a texel's footprint (§2.6's virtual camera, issue 12). A texel's value
// is the integral of the aBRDF over its footprint on the reference plane. At level L the texel is
// a K×K grid of cells (K = 2^(L+1)), each holding one jittered sample; a cell that splits becomes
// four cells of level L+1 (the one holding the parent's sample keeps it). Each light of a
// (texel, view) refines its own cells:
//  - level 0 (2×2) and the hit map's own level (4×4 when the budget allows) cost no camera ray;
//  - a geometric edge of the texel (between neighbouring map samples, or in the view's edge
//    table) takes the light to the map's level;
//  - a light that lights every receiver of the texel (nothing in its map over their footprint
//    lies above the lowest) takes no visibility test; over flat faces its value is closed form:
//    Σ area fraction × unshadowed value per face, the area fractions from one refinement per
//    (texel, view) where neighbouring samples see different faces;
//  - the same test face by face (a flat face's plane over the whole texel): samples on a lit
//    face take no visibility test and cells holding only lit faces do not split; a light with
//    every face lit takes the closed form;
//  - a shadow edge in the footprint of a quadrant (the light's edge table where its map
//    holds the quadrant's receivers, with something above them) takes that quadrant to the
//    map's level, and there the cells the edge may cross one level further; the light's
//    samples take exact shadow rays where the shadow map's 3 × 3 taps disagree; a flagged
//    light lit at all its samples with agreeing taps takes the closed form;
//  - beyond, while the light's error estimate (from neighbouring-cell differences) exceeds
//    tolerance × max(value, floor), the cells that differ from a neighbour, and their four
//    neighbours, split; finer cells trace camera rays once per (texel, view), shared by every
//    light; `edgeCells` also splits the map-level cells whose footprint holds a geometric edge,
//    and the face refinement's cells likewise.
// Samples of one flat face (material and normals shared) share their unshadowed value.
// docs/conventions.md ("Tile and texels") states the rules and thresholds.
// Sample positions depend on (seed, texel, level, stratum) only — not on the view, the thread or
// the chunk — so runs are deterministic with any thread count, resume to the same bytes, and the
// studio's single-pair preview equals the stored value.
#pragma once
#include <btf/sim/direct.h>
#include <btf/sim/network.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

namespace btf {

struct AdaptiveSettings {
  int maxK = 8;             // finest level: maxK × maxK samples (a power of two, 2..64)
  float tolerance = 0.01f;  // estimated error per value, relative to max(value, floor)
  /// At the map's level, also split every cell whose footprint holds an edge of the view's edge
  /// table (geometric slivers that every map sample missed; shadow-edge cells always split);
  /// the face refinement (closed-form values' areas) does the same.
  bool edgeCells = false;
};

/// What the texels took, summed over a run (atomic: kernels run on every thread).
struct AdaptiveStats {
  static constexpr int kLevels = 6;  // 2×2, 4×4, 8×8, 16×16, 32×32, 64×64
  // (texel, view, light) values by the finest level they reached
  std::array<std::atomic<uint64_t>, kLevels> values{};
  std::atomic<uint64_t> samples{0};  // Σ samples the values took
  /// Σ (sample, light) evaluations made — a closed-form value costs one per face, not its
  /// samples (local: the run's time estimate; not summed over a cluster's ranks).
  std::atomic<uint64_t> evaluations{0};
  std::atomic<uint64_t> texelViews{0}, edgeTexelViews{0}, cameraRays{0};
  std::atomic<double> errorSq{0}, valueSq{0};  // Σ estimated error², Σ value² (luminance)
  /// Mean samples per value, the estimated relative RMS error, and the histogram as JSON.
  std::string json() const;
  double meanSamples() const;
  double estimatedRelativeError() const;
  /// "4²: 71 %, 16²: 22 %, …"
  std::string histogramText() const;
  /// Every counter as numbers, and their sum over the ranks of a cluster job.
  std::vector<double> toVector() const;
  void assign(const std::vector<double>& v);
};

class AdaptiveTexelSampler {
 public:
  /// The floor of the relative tolerance follows the scene's brightest material.
  /// `maps` must have been built with spp 2 or 4 (the map's level); `gather` (may be null) adds
  /// the network's indirect light over the map's samples at edges, level 0 elsewhere.
  AdaptiveTexelSampler(const PeriodicTracer& tracer, const std::vector<Material>& materials,
                       const DirectionSet& dirs, const HitMaps& maps,
                       const DirectIllumination& direct, const NetworkGather* gather,
                       AdaptiveSettings settings, AdaptiveStats* stats);
  /// aBRDF of texel (i, j) seen from `view` for every light: out[l * 3 + c]. Returns the number
  /// of (sample, light) evaluations.
  int64_t eval(int i, int j, int view, float* out) const;

 private:
  const PeriodicTracer& m_tracer;
  const DirectionSet& m_dirs;
  const HitMaps& m_maps;
  const DirectIllumination& m_direct;
  const NetworkGather* m_gather;
  AdaptiveSettings m_settings;
  AdaptiveStats* m_stats;
  int m_mapLevel = 0, m_maxLevel = 0;
  double m_texelSize = 1;
  float m_floor = 0.05f;  // values below it are judged by absolute error
  bool m_shadowEdges = false;
  std::vector<float> m_invCos;  // per direction: 1 / cos θ
  float m_litMargin = 0;        // a map depth this far beyond a receiver still lights it
  float m_toSampleX = 1, m_toSampleY = 1;
  std::vector<float> m_slopeX, m_slopeY;  // ωx/ωz, ωy/ωz of every light
};

/// Level of a K×K set (K = 2 → 0, 4 → 1, …); -1 when K is not a power of two in 2..32.
int adaptiveLevel(int K);

}  // namespace btf
