// Hit maps (§2.6.3, §4.2.3): for every direction ω of the set, the first hit of every texel
// sample's ray — the ray through (x, y, 0) travelling along −ω. Each map is at once the camera
// image of ω and the shadow map of ω (parallel camera and light share the structure), and its
// depths are the visibility map VMF(u, v, θ, φ) of §4.3.2.
#pragma once
#include <btf/core/parallel.h>
#include <btf/core/progress.h>
#include <btf/directions/direction_set.h>
#include <btf/trace/periodic_tracer.h>

#include <cstdint>
#include <vector>

namespace btf {

/// The K×K samples of each of the Nu×Nv texels. With K = 1 the sample is the texel centre;
/// with K > 1 samples are jittered inside their stratum from a counter-based stream (seed,
/// sample index), so any subset can be regenerated identically.
struct SampleGrid {
  int nu = 1, nv = 1, spp = 1;
  double Lx = 1, Ly = 1;
  uint64_t seed = 1;
  int su() const { return nu * spp; }
  int sv() const { return nv * spp; }
  int64_t samples() const { return int64_t(su()) * sv(); }
  /// Reference-plane position of sample (a, b), a in [0, su), b in [0, sv).
  DVec3 position(int a, int b) const;
  /// Index of the s-th sample (s in [0, K²)) of texel (i, j) in the sample grid.
  int64_t sampleIndex(int i, int j, int s) const {
    return int64_t(j * spp + s / spp) * su() + (i * spp + s % spp);
  }
};

class HitMaps {
 public:
  /// Traces every (direction, sample) ray; progress counts directions.
  void build(const PeriodicTracer& tracer, const DirectionSet& dirs, const SampleGrid& grid,
             ProgressReporter* progress = nullptr, const CancelToken* cancel = nullptr);
  /// Bytes per (direction, sample) record, for memory estimates.
  static constexpr uint64_t kBytesPerSample = 16;

  const SampleGrid& grid() const { return m_grid; }
  int directions() const { return m_nDirs; }
  // Structure of arrays, index dir * samples + sample.
  uint32_t prim(int dir, int64_t s) const { return m_prim[idx(dir, s)]; }
  float depth(int dir, int64_t s) const { return m_depth[idx(dir, s)]; }
  float bu(int dir, int64_t s) const { return m_u[idx(dir, s)]; }
  float bv(int dir, int64_t s) const { return m_v[idx(dir, s)]; }
  const uint32_t* primRow(int dir) const { return &m_prim[idx(dir, 0)]; }
  const float* depthRow(int dir) const { return &m_depth[idx(dir, 0)]; }
  /// The finest block maxima of direction `dir`'s depths (2 × 2 samples each, su/2 per row);
  /// null without edge tables.
  const float* blockMaxRow(int dir) const {
    return m_blockMax.empty() ? nullptr
                              : &m_blockMax[size_t(dir) * m_blockPerDir + m_blockLevels[0].offset];
  }
  uint64_t raysTraced() const { return uint64_t(m_nDirs) * uint64_t(m_grid.samples()); }

  /// Texel-resolution visibility map of a direction: per texel, the fraction of its samples that
  /// hit geometry (coverage) and the mean signed distance of those hits to the reference plane
  /// along ω (0 when none hit). Two floats per texel, row-major.
  std::vector<float> vmf(int dir) const;

  /// Edge tables (adaptive sampling): per direction, a summed-area table of the map samples that
  /// sit on a discontinuity of the map — a hit next to a miss, two materials, a depth step of
  /// more than three sample spacings (a silhouette seen from ω; for a light, where its shadows
  /// begin) or a crease (face normals more than ~25° apart). 4 bytes per (direction, sample).
  void buildEdgeTables(const TileGeometry& geom, const CancelToken* cancel = nullptr);
  bool hasEdgeTables() const { return !m_edgeSat.empty(); }
  /// Edge samples of direction `dir` in the sample rectangle [a0, a1) × [b0, b1), wrapped
  /// periodically (any integers; a span wider than the map counts the whole map).
  uint32_t edgeCount(int dir, int a0, int a1, int b0, int b1) const;
  /// An upper bound of the hit depths of direction `dir` over the sample rectangle
  /// [a0, a1) × [b0, b1) (wrapped as edgeCount; the maximum over the blocks it touches of a
  /// pyramid of block maxima, 2 × 2 samples and coarser, at most 5 blocks a side; −∞ where all
  /// miss). A receiver at distance r along the light is lit by every map tap of the rectangle
  /// when this is ≤ r.
  float maxDepth(int dir, int a0, int a1, int b0, int b1) const;
  /// Edge tables and the block-maximum pyramid (~4/3 B).
  static constexpr uint64_t kEdgeBytesPerSample = 6;

 private:
  size_t idx(int dir, int64_t s) const {
    return size_t(dir) * size_t(m_grid.samples()) + size_t(s);
  }
  SampleGrid m_grid;
  int m_nDirs = 0;
  std::vector<uint32_t> m_prim;
  std::vector<float> m_depth, m_u, m_v;
  std::vector<uint32_t> m_edgeSat;  // per direction (su + 1) × (sv + 1)
  struct BlockLevel {
    int nu, nv;     // blocks per side
    size_t offset;  // in a direction's block maxima
  };
  std::vector<BlockLevel> m_blockLevels;
  size_t m_blockPerDir = 0;
  std::vector<float> m_blockMax;  // per direction, every level
};

/// The ray of a texel sample for direction ω: returns the hit and writes the signed distance of
/// the hit to the plane point along ω (positive above z = 0).
RayHit traceSampleRay(const PeriodicTracer& tracer, const DVec3& planePoint, const DVec3& w,
                      float* depth);

}  // namespace btf
