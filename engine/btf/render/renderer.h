// The object renderer of `btfsim render` (docs/render.md; thesis §4.3): one object under a
// directional light, seen by an orthographic or perspective camera, in three modes —
//  - flat:   the BTF looked up on the base surface (the viewer's old way, no silhouettes);
//  - mapped: §4.3 — a shell of prisms extruded along the interpolated normals over the tile's
//            height range; each ray is followed face to face through the shell, in object and
//            texture space at once; on each prism's segment the visibility map (VMF) of the
//            segment's texture-space direction, read where the segment's line crosses the
//            reference plane, says whether the relief is hit; the light direction is the one
//            found by tracing from the hit toward the light through the shell (out through a
//            bottom face → shadow; the direction of the prism where it leaves otherwise), and a
//            relief hit elsewhere on the object on the way out shadows it. A ray that leaves the
//            shell without a hit is background: the silhouette;
//  - exact:  the scene's micro-geometry itself mapped through the same prisms onto the object as
//            real triangles (clipped at the base triangles' texture-space edges) and path traced
//            with the scene's materials — the reference.
// Texture ("tile") space: x = u·T·Lx, y = v·T·Lx (T tiles per uv unit, isotropic), h = the tile's
// z; world height = h · k_v · relief scale, k_v the local world length of a tile unit at the
// vertex (area-weighted over its triangles). Directions are taken in the orthonormal frame of
// the point (interpolated normal, the tile's x axis projected), as the BTF was simulated.
#pragma once
#include <btf/core/math.h>
#include <btf/core/parallel.h>
#include <btf/core/progress.h>
#include <btf/core/rng.h>
#include <btf/geometry/mesh.h>
#include <btf/render/mesh_tracer.h>
#include <btf/render/objects.h>
#include <btf/scene/material.h>
#include <btf/scene/scene.h>

#include <memory>
#include <string>
#include <vector>

namespace btf {

class Decoder;
class DirectionSet;
struct BtfInfo;

struct RenderSettings {
  int width = 256, height = 256;
  int spp = 4;                         // samples per pixel (jittered)
  double camTheta = 35, camPhi = -90;  // degrees: where the camera is, seen from the object
  bool perspective = false;
  double fovDeg = 35;                      // perspective: vertical field of view
  double zoom = 1;                         // > 1 magnifies
  double lightTheta = 45, lightPhi = -30;  // degrees: direction toward the light (world)
  double irradiance = 1;                   // of the light on a surface facing it
  double environment = 0;                  // radiance of a constant sky all around (0 = none)
  double tiling = 4;                       // tiles per uv unit
  double reliefScale = 1;                  // multiplies the relief's heights on the object
  int bounces = 0;                         // exact: reflections per path (0 = unbounded, RR)
  uint64_t seed = 1;
  // Texel levels (docs/mip.md): flat and mapped choose each sample's level from its footprint in
  // texture space (ray differentials) and blend the two nearest (trilinear); an elongated
  // footprint takes up to maxAniso taps along its long axis at the level of its short one.
  bool mip = true;
  int forceLevel = -1;     // ≥ 0: every lookup at this level (the VMF too), no footprint
  bool showLevel = false;  // the chosen level in false colour instead of radiance
  int maxAniso = 8;
};

/// False colour of a texel level (0 blue … 1 cyan … 2 green … 3 yellow … 4 red … ≥ 5 magenta,
/// linear in between): what --show-level draws.
Rgb levelColour(double level);

/// A rendered image: RGB radiance (linear), coverage (fraction of the pixel's samples that met
/// the object), row 0 at the top.
struct RenderImage {
  std::string mode;
  int width = 0, height = 0;
  std::vector<float> rgb, alpha;
  double seconds = 0;
  uint64_t samples = 0, rays = 0;  // rays: every Embree query
  uint64_t triangles = 0;          // what was traced: base, shell faces or exact triangles
  /// flat and mapped: per pixel, the mean over its covered samples of the texel level used and
  /// of the footprint's area in level-0 texels (−1 and 0 where nothing was looked up).
  std::vector<float> lod, footprintTexels;
};

/// The tile a BTF was simulated from: its embedded scene built into triangles, and whether the
/// tile is flat (the reference plane alone, which needs no visibility map). Throws when the file
/// carries no scene.
struct BtfTile {
  Scene scene;
  TileGeometry geometry;
  bool flat = false;
};
BtfTile tileOfBtf(const BtfInfo& info, const std::string& path, uint64_t memoryBudget);

/// A raw store's visibility map (level 0) as the GLSL shell march reads it: for each direction
/// of the set, texels × (coverage, height) (non-finite entries zeroed), and each direction's z.
struct VmfTable {
  int nu = 0, nv = 0, nDirs = 0;
  std::vector<float> map, dirZ;
};
/// Reads the visibility map of raw store `vmfPath` for the BTF `of` (read from `ofPath`), after
/// checking that it belongs to it (texels, directions, scene); a clear error otherwise.
VmfTable readVmfTable(const std::string& vmfPath, const BtfInfo& of, const std::string& ofPath);

/// The shell of a RenderScene flattened for the GLSL march (shaders/btf_shell.glsl): one float
/// array (indices as floats, exact below 2^24) of sections at the given offsets —
///  vertices: 3 per shell vertex (2·welded + level);
///  faces:    6 per face: its 3 vertices, the prism on the normal's side, the other (−1: none),
///            kind (0 top, 1 bottom, 2 side);
///  prisms:   21 per prism: faces[8], welded vertices[3], neighbours[3] (−1 none), open bits,
///            tile corners x0 y0 x1 y1 x2 y2; and 6 per prism in the frames section: its base
///            triangle's world tile axes T, B;
///  normals:  3 per welded vertex (unit);
///  nodes:    8 per BVH node in depth-first order: box min, box max, the node after its subtree,
///            and −1 (inner: its first child follows) or its leaf's offset in the leaves
///            section, where a count precedes the leaf's face indices.
struct ShellGpuTables {
  std::vector<float> data;
  int vertices = 0, faces = 0, prisms = 0, welded = 0, nodes = 0;
  int oVertex = 0, oFace = 0, oPrism = 0, oFrame = 0, oNormal = 0, oNode = 0, oLeaf = 0;
  double eps = 0, hlo = 0, hhi = 0, Lx = 1, Ly = 1;
};

/// The camera of a RenderScene: ray(sx, sy) (screen coordinates in [−1, 1], y up) starts at pos
/// (perspective) or pos + right·sx·hw + up·sy·hh (orthographic).
struct CameraFrame {
  DVec3 pos{0}, fwd{0}, right{0}, up{0};
  double hw = 1, hh = 1;
  bool perspective = false;
};
/// The camera of settings `s` around an object of bounding radius `radius` (what every mode
/// renders through; the studio's GPU mapped view too).
CameraFrame cameraFrame(const RenderSettings& s, double radius);
/// The direction toward the light of settings `s` (world, unit).
DVec3 lightDirection(const RenderSettings& s);

/// The BTF values and visibility map the flat and mapped modes read, in tile units and
/// tile-frame directions (z up). Raw stores are read whole into memory (every chunk checksum
/// verified); compressed files are decoded whole when they fit in half the memory budget, per
/// value otherwise.
class BtfSampler {
 public:
  /// Where a lookup's filter reaches: the pixel sample's footprint, a parallelogram of axes a, b
  /// (tile units) around the point, covered by na × nb taps at the centres of its cells, each
  /// read trilinearly at the level of detail `lod` (continuous, 0 = the simulated texels, k =
  /// 2^k texels per level texel) whose texels are as wide as a cell.
  struct Footprint {
    double lod = 0;
    glm::dvec2 a{0}, b{0};
    int na = 1, nb = 1;
  };
  /// `vmfPath` (a raw store of the same scene) supplies the visibility map when `path` has none
  /// (a .cbtf); "" = none. `flatTile`: the tile is flat, so a missing VMF is the plane z = 0.
  /// `mip`: the texel levels too (a pyramid .cbtf decodes its own; otherwise box-filtered from
  /// level 0 in memory, with the visibility map's levels).
  BtfSampler(const std::string& path, const std::string& vmfPath, bool flatTile,
             uint64_t memoryBudget, const CancelToken* cancel = nullptr, bool mip = false);
  ~BtfSampler();
  const BtfInfo& info() const;
  bool hasVmf() const { return m_hasVmf; }
  /// Levels held (1 without mip).
  int levels() const { return int(m_lv.size()); }
  /// Whether the levels come from the file (a pyramid .cbtf) rather than box filtering here.
  bool fileLevels() const { return m_fileLevels; }
  /// The footprint of a pixel sample whose neighbours lie dx, dy away in tile units: its short
  /// axis cut in up to two cells (fewer below two level-0 texels), its long axis in cells as
  /// wide, up to maxAniso times as many; lod = log2 of the widest cell in level-0 texels,
  /// clamped to [0, levels − 1] (past maxAniso the cells stretch and the level rises with them).
  Footprint footprint(const glm::dvec2& dx, const glm::dvec2& dy, int maxAniso) const;
  /// aBRDF at tile position (x, y) (bilinear between texels, periodic), directions interpolated
  /// on the set; wo, wi unit with z > 0. With a footprint: trilinear between its two levels,
  /// averaged over its taps.
  Rgb eval(double x, double y, const DVec3& wo, const DVec3& wi,
           const Footprint* fp = nullptr) const;
  /// The VMF of level `level` at (x, y) (nearest texel) for direction w (interpolated): coverage
  /// in [0, 1] and the height above the reference plane of the hit of the line through (x, y, 0)
  /// along −w.
  void vmf(double x, double y, const DVec3& w, float* coverage, float* height, int level = 0) const;
  uint64_t memoryBytes() const;
  /// For a constant environment: per texel and view, Σ_l aBRDF(t, v, l)·w_l over the set's light
  /// directions, w_l the cosine-weighted solid angle of l's ring band shared by its count (they
  /// sum to π): the reflected radiance under a sky of radiance 1. Computed once (a pass over
  /// every value).
  void prepareAmbient(const CancelToken* cancel = nullptr);
  /// That sum at (x, y) (bilinear, periodic) for view wo (interpolated); prepareAmbient first.
  Rgb ambient(double x, double y, const DVec3& wo, const Footprint* fp = nullptr) const;

 private:
  struct Level {
    int nu = 1, nv = 1;
    std::unique_ptr<Decoder> dec;  // per-value access when the values are not in memory
    const float* data = nullptr;   // texel-major values, in m_data or m_coarse
    std::vector<float> vmf;        // levels ≥ 1: nDirs × texels × 2
    size_t ambient = 0;            // its first texel's offset in m_ambient (floats)
  };
  std::shared_ptr<DirectionSet> m_dirs;
  std::vector<Level> m_lv;
  std::vector<float> m_data;     // level 0, texel-major values
  std::vector<float> m_coarse;   // levels 1.., texel-major, one after the other
  std::vector<float> m_vmf;      // level 0: nDirs × texels × 2
  std::vector<float> m_ambient;  // per level, texels × views × 3 (prepareAmbient)
  bool m_hasVmf = false, m_flat = false, m_fileLevels = false;
  int m_nu = 1, m_nv = 1, m_n = 1;
  double m_Lx = 1, m_Ly = 1;
  Rgb value(int level, int64_t texel, int view, int light) const;
  /// fn(texel, weight) for the four texels of `level` around (x, y) (tile units), bilinear and
  /// periodic.
  template <class Fn>
  void bilinear(int level, double x, double y, Fn&& fn) const;
  /// fn(level, x, y, weight) for the lookups a footprint asks for (one at level 0 without).
  template <class Fn>
  void filtered(double x, double y, const Footprint* fp, Fn&& fn) const;
};

/// The object, its tile space and its shell, shared by the three modes.
class RenderScene {
 public:
  /// `zmin`, `zmax`: the tile's height range (tile units). Throws btf::Error when the object
  /// has degenerate texture coordinates or when the shell would self-intersect (relief too tall
  /// for the object's curvature), naming the numbers.
  RenderScene(ObjectMesh object, double Lx, double Ly, double zmin, double zmax,
              const RenderSettings& s);
  ~RenderScene();
  const ObjectMesh& object() const { return m_obj; }
  double heightScale() const { return m_K; }   // world units per tile unit of height
  double worldPerTile() const { return m_k; }  // world units per tile unit along the surface
  size_t shellFaces() const { return m_faces.size(); }
  size_t prisms() const { return m_prisms.size(); }

  RenderImage renderFlat(const BtfSampler& btf, const CancelToken* cancel,
                         ProgressReporter* progress) const;
  RenderImage renderMapped(const BtfSampler& btf, const CancelToken* cancel,
                           ProgressReporter* progress) const;
  /// Builds the mapped micro-geometry (refused past maxTriangles) and path traces it.
  RenderImage renderExact(const TileGeometry& tile, const std::vector<Material>& materials,
                          uint64_t maxTriangles, const CancelToken* cancel,
                          ProgressReporter* progress) const;
  /// The shell and its bounding volume hierarchy for the GLSL march (the studio's mapped view).
  ShellGpuTables gpuTables() const;
  /// Triangles the exact mode would build (an estimate, before building).
  uint64_t exactTriangleEstimate(const TileGeometry& tile) const;

  struct Prism {
    uint32_t w[3];                 // welded vertex ids
    uint32_t tri;                  // base triangle
    glm::dvec2 xy[3];              // tile-space corners
    uint8_t open = 0;              // bit i: edge (w[i], w[i+1]) is on the object's boundary
    int32_t nb[3] = {-1, -1, -1};  // the prism across edge i
    uint32_t face[8] = {};         // top, bottom, then the two triangles of each side i
  };
  /// True when tile point x, given in prism p's coordinates, lies on the object: found by
  /// walking across edges toward it (translating at seams), false past an open edge.
  bool onObject(int p, glm::dvec2 x) const;
  struct Face {
    uint32_t v[3];                // shell vertex ids: 2·welded + level (0 bottom, 1 top)
    int32_t prism[2] = {-1, -1};  // [0]: on the side the face normal points to
    uint8_t kind = 0;             // 0 top, 1 bottom, 2 side
    DVec3 n{0};
  };

 private:
  struct Camera;
  /// A camera sample's ray differentials: the rays of its neighbours one sample spacing away.
  struct RayDiff {
    DVec3 dox{0}, doy{0}, ddx{0}, ddy{0};
  };
  /// What a sample's shading reports beside its colour: its footprint (lod < 0: none).
  struct SampleInfo {
    double lod = -1, texels = 0;
    void set(const BtfSampler::Footprint& fp, const BtfSampler& btf);
  };
  struct MarchHit {
    DVec3 world{0}, tile{0}, crossing{0}, wo{0, 0, 1};
    int prism = -1;
    BtfSampler::Footprint fp;
  };
  enum MarchResult { kMiss = 0, kRelief = 1, kAbsorbed = 2 };
  /// Follows o + t d (t > tmin) through the shell; kRelief fills `hit`.
  MarchResult march(const DVec3& o, const DVec3& d, double tmin, const BtfSampler& btf, Rng& rng,
                    MarchHit* hit, uint64_t* rays, const RayDiff* diff = nullptr) const;
  /// The footprint at world point p of base triangle `tri` of the camera ray (o, d) with its
  /// differentials (tangent-plane transfer, then the triangle's texture map): level 0 when mip is
  /// off, the forced level when one is.
  BtfSampler::Footprint footprintAt(uint32_t tri, const DVec3& p, const DVec3& o, const DVec3& d,
                                    const RayDiff& diff, const BtfSampler& btf) const;
  /// The tile-frame light direction at a relief hit, false when the light is blocked.
  /// The nearest of prism `prism`'s own 8 faces along o + t d with t > tmin (the march's step
  /// inside the shell, without a BVH query); false when none is found (numerically), and the
  /// caller asks Embree.
  bool nextFace(int prism, const DVec3& o, const DVec3& d, double tmin, MeshHit* h) const;
  bool lightAt(const MarchHit& hit, const BtfSampler& btf, Rng& rng, DVec3* wi,
               uint64_t* rays) const;
  bool segmentHit(int prism, const DVec3& tin, const DVec3& tout, const DVec3& pin,
                  const DVec3& pout, const DVec3& d, const BtfSampler& btf, Rng& rng, bool* ahead,
                  MarchHit* hit, int vmfLevel) const;
  Camera camera() const;
  /// A world direction in the tile frame of prism `prism` at tile point t (unit).
  DVec3 tileDir(int prism, const DVec3& t, const DVec3& d) const;
  DVec3 tileCoords(const Face& f, int prism, float bu, float bv) const;
  void frameOf(uint32_t baseTri, const DVec3& n, DVec3* t, DVec3* b) const;
  template <class Shade>
  RenderImage renderWith(const std::string& mode, const CancelToken* cancel,
                         ProgressReporter* progress, Shade&& shade) const;

  ObjectMesh m_obj;
  RenderSettings m_s;
  double m_Lx, m_Ly, m_hlo, m_hhi, m_k, m_K, m_eps;
  std::vector<Vec3> m_wpos, m_wnrm;  // welded vertices
  std::vector<double> m_wK;          // per welded vertex: world height per tile unit
  std::vector<DVec3> m_sv;           // shell vertices: 2·welded + level
  std::vector<Prism> m_prisms;
  std::vector<Face> m_faces;
  std::vector<DVec3> m_triT, m_triB;  // per base triangle: world tile axes (unit)
  std::vector<uint32_t> m_baseKept;   // base triangles traced by flat (non-degenerate)
  std::unique_ptr<MeshTracer> m_base, m_shell;
  DVec3 m_light{0, 0, 1};
};

/// Relative RMSE of `img` against `ref` over the pixels either covers (RGB), and the coverage
/// mismatch: pixels covered (alpha ≥ ½) in one and not the other, over the reference's covered
/// pixels.
struct ImageError {
  double relRmse = 0, coverageMismatch = 0;
  /// Over the pixels both images cover fully (alpha ≥ 0.999): the shading without the
  /// silhouettes' partly covered pixels, which one sample per pixel cannot resolve.
  double relRmseInterior = 0;
  int64_t interiorPixels = 0;
  int64_t refPixels = 0, mismatchPixels = 0;
  int64_t extraPixels = 0;  // of the mismatch: covered by the image, not by the reference
};
ImageError compareImages(const RenderImage& img, const RenderImage& ref);

}  // namespace btf
