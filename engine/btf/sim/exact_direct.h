// Exact direct light by area (thesis §2.6, §4.2.3): under a parallel camera and a directional
// light a flat face of constant shading normal shades uniformly, so a texel's direct aBRDF is
// Σ_faces area(footprint ∩ visible(face, view) ∩ lit(face, light)) / area(footprint) × the
// face's f_r · (n·ωi) / cos θi — no samples. Per direction of the set, once: the part of every
// face that is first seen from that direction (hidden-surface removal of the periodic tile's
// triangles, their copies included, in each face's own plane; polygons by Clipper, in
// integers). That part is what a view sees and what a light lights. Per (view, light): each
// face's seen part ∩ its lit part, projected along the view onto the reference plane, and its
// area spread over the texels by an exact area rasteriser (sim/area_raster.h).
// Faces with interpolated (smooth) normals are occluders here but shaded by the sampled kernel.
#pragma once
#include <btf/core/parallel.h>
#include <btf/core/progress.h>
#include <btf/directions/direction_set.h>
#include <btf/geometry/mesh.h>
#include <btf/scene/material.h>
#include <btf/sim/area_raster.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace btf {

struct ExactStats {
  double hsrSeconds = 0;      // the hidden-surface removal of every direction
  int64_t faces = 0;          // triangles of non-zero area
  int64_t flatFaces = 0;      // of which shaded here (constant normal)
  int64_t partialRegions = 0;  // (direction, face) parts neither empty nor whole
  int64_t occluderTests = 0;   // (direction, face, occluder copy) overlaps clipped
  uint64_t regionBytes = 0;
};

class ExactDirect {
 public:
  /// The tile seen on an nu × nv texel grid from every direction of `dirs` (views and lights
  /// alike). The geometry, materials and directions must outlive this object.
  ExactDirect(const TileGeometry& geom, const std::vector<Material>& materials,
              const DirectionSet& dirs, int nu, int nv);
  ~ExactDirect();
  ExactDirect(const ExactDirect&) = delete;
  ExactDirect& operator=(const ExactDirect&) = delete;

  /// Regions for the smooth faces too (before prepare()). The kernel shades those by samples
  /// and needs the flat faces' regions only, so by default the smooth faces occlude but get none
  /// (on a curved tile most of the hidden-surface removal's work); visibleFraction() of a smooth
  /// face needs this on.
  void setEveryFace(bool on) { m_everyFace = on; }
  /// Shade the smooth faces here too (before prepare()): their seen ∩ lit parts from the same
  /// removal, shaded by the plane through the values at their vertices' shading normals (a
  /// quadrature of second order in the face's size, not samples). Off: the sampled kernel
  /// shades them on the hit maps.
  void setShadeSmooth(bool on) { m_shadeSmooth = on; }
  bool shadeSmooth() const { return m_shadeSmooth; }
  /// Hidden-surface removal for every direction (parallel; progress counts directions).
  void prepare(ProgressReporter* progress = nullptr, const CancelToken* cancel = nullptr);

  /// Whether triangle `prim` is shaded here (non-zero area and one shading normal).
  bool shades(uint32_t prim) const;
  /// shades() of every triangle: what the sampled kernel leaves out.
  std::vector<uint8_t> shadedMask() const;
  bool prepared() const { return m_prepared; }
  /// Every triangle of non-zero area is flat: the whole direct light is exact.
  bool allFlat() const { return m_stats.flatFaces == m_stats.faces; }
  /// Every triangle of non-zero area is shaded here (flat, or smooth with setShadeSmooth): the
  /// sampled kernel adds no direct light.
  bool allShaded() const { return allFlat() || m_shadeSmooth; }
  const ExactStats& stats() const { return m_stats; }

  /// Up to `bytes` (0: none) of whole rows of every view kept between evalView calls: a run
  /// whose chunks hold a few rows each computes a block of rows per view once, and the chunks
  /// after it copy theirs (a face is clipped once per block, not once per chunk it spans). The
  /// values are the same bits either way. Not while evalView runs.
  void setRowCache(uint64_t bytes);
  /// The flat faces' direct aBRDF of texels [t0, t1) (row-major over nu) seen from `view`, every
  /// light: texel t's light l, channel c at out[(t − t0)·texelStride + 3·l + c] (overwritten).
  void evalView(int view, int64_t t0, int64_t t1, float* out, size_t texelStride) const;
  /// The same for n scattered texels (any order, repeats allowed): texel texels[k]'s light l,
  /// channel c at rows[k][3·l + c] (overwritten). The view is prepared once and each light
  /// rastered over the runs of rows that hold a texel — what a subset of the grid (a codec's
  /// training texels, an estimate's probes) costs, instead of one whole view per texel.
  void evalViewTexels(int view, const int64_t* texels, size_t n, float* const* rows) const;
  /// One (view, light) pair over the whole grid: image[3·(j·nu + i) + c].
  void evalPair(int view, int light, float* image) const;

  /// Area fraction of triangle `prim` that direction `dir` sees first (for tests): 0 … 1; a
  /// smooth face's only with setEveryFace(true).
  double visibleFraction(int dir, uint32_t prim) const;

 private:
  struct Face;
  struct DirRegions;
  struct ViewFace;
  struct SubPoint;
  struct ViewFaces;
  struct RowBlock {  // rows [r0, r1) of one view, every light: (t − r0·nu)·nL·3 + 3·l + c
    std::mutex lock;
    int r0 = 0, r1 = 0;
    std::vector<float> values;
  };
  void hsr(int dir, DirRegions* out, int64_t* tests) const;
  void evalRows(int view, int64_t t0, int64_t t1, float* out, size_t texelStride) const;
  void prepareView(int view, ViewFaces* out) const;
  void rasterLight(int view, int light, const ViewFaces& faces, int row0, int row1,
                   AreaRaster* raster) const;

  const TileGeometry& m_geom;
  const std::vector<Material>& m_materials;
  const DirectionSet& m_dirs;
  int m_nu, m_nv;
  std::vector<Face> m_faces;
  std::vector<DirRegions> m_regions;  // per direction
  ExactStats m_stats;
  std::vector<std::unique_ptr<RowBlock>> m_rowBlocks;  // per view, when setRowCache gave rows
  int m_blockRows = 0;
  bool m_prepared = false;
  bool m_everyFace = false;
  bool m_shadeSmooth = false;
};

}  // namespace btf
