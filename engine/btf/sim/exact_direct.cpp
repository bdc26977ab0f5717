// Exact direct light by area: the hidden-surface removal per direction and the per-(view, light)
// accumulation (exact_direct.h says what and why; docs/decisions/exact-visibility.md how).
#include <btf/core/error.h>
#include <btf/core/run_context.h>
#include <btf/sim/exact_direct.h>
#include <clipper.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

namespace btf {

namespace cl = ClipperLib;

namespace {

struct P2 {
  double x, y;
};

// Sutherland–Hodgman: the part of convex polygon `in` where a·x + b·y + c ≥ 0.
void clipHalf(const std::vector<P2>& in, double a, double b, double c, std::vector<P2>* out) {
  out->clear();
  const size_t n = in.size();
  for (size_t i = 0; i < n; ++i) {
    const P2& p = in[i];
    const P2& q = in[(i + 1) % n];
    const double fp = a * p.x + b * p.y + c, fq = a * q.x + b * q.y + c;
    if (fp >= 0) out->push_back(p);
    if ((fp >= 0) != (fq >= 0)) {
      const double t = fp / (fp - fq);
      out->push_back({p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)});
    }
  }
}

double polyArea(const std::vector<P2>& p) {
  double a = 0;
  for (size_t i = 0, n = p.size(); i < n; ++i) {
    const P2& u = p[i];
    const P2& v = p[(i + 1) % n];
    a += u.x * v.y - v.x * u.y;
  }
  return 0.5 * a;
}

double pathsArea(const cl::Paths& ps) {
  double a = 0;
  for (const cl::Path& p : ps) a += cl::Area(p);
  return a;
}

// Runs the clipper and returns its rings oriented by what they are — outer rings counter-clockwise
// (positive area), holes clockwise — from the polygon tree: the flat output's orientation is not
// reliable (Clipper 6.4.2 returns some outer rings clockwise, measured on the leather tile).
void execute(cl::Clipper& c, cl::ClipType type, cl::Paths* out) {
  cl::PolyTree tree;
  c.Execute(type, tree, cl::pftNonZero, cl::pftNonZero);
  out->clear();
  for (cl::PolyNode* n = tree.GetFirst(); n; n = n->GetNext()) {
    if (n->Contour.size() < 3) continue;
    out->push_back(n->Contour);
    if ((cl::Area(out->back()) < 0) != n->IsHole()) std::reverse(out->back().begin(), out->back().end());
  }
}

inline double xOf(const P2& p) { return p.x; }
inline double yOf(const P2& p) { return p.y; }
inline double xOf(const cl::IntPoint& p) { return double(p.X); }
inline double yOf(const cl::IntPoint& p) { return double(p.Y); }

// A closed ring in doubles (a face's local integers, converted exactly) with its bounds.
struct DRing {
  std::vector<P2> pts;
  double x0, x1, y0, y1;
};

void toRing(const cl::IntPoint* p, size_t n, DRing* r) {
  r->pts.resize(n);
  r->x0 = r->y0 = 1e300, r->x1 = r->y1 = -1e300;
  for (size_t i = 0; i < n; ++i) {
    const double x = double(p[i].X), y = double(p[i].Y);
    r->pts[i] = {x, y};
    r->x0 = std::min(r->x0, x), r->x1 = std::max(r->x1, x);
    r->y0 = std::min(r->y0, y), r->y1 = std::max(r->y1, y);
  }
}

constexpr uint8_t kHidden = 0, kWhole = 1, kPartial = 2;
// Smooth faces' shading: sub-triangles until their corners' normals are this close (radians),
// at most 4^kMaxShadeLevel of them.
constexpr double kShadeAngle = 4.0 * 3.14159265358979323846 / 180;
constexpr int kMaxShadeLevel = 3;
// … as many as bring the miss of the plane through the corners' values at the edges' midpoints
// (divided by 4 per split) under this fraction of the face's largest value.
constexpr float kShadeTolerance = 0.01f;
constexpr double kIntRange = double(1 << 29);  // local coordinates × scale stay within ±2^29

}  // namespace

struct ExactDirect::Face {
  DVec3 a0{0}, u{0}, v{0}, n{0};  // first vertex; orthonormal basis of the plane; unit normal
  double scale = 1;               // local units → Clipper integers
  double area = 0, diameter = 0;
  P2 loc[3];     // the triangle in local coordinates (counter-clockwise)
  cl::Path tri;  // the same in integers
  Vec3 ns{0};    // the constant shading normal (flat faces)
  Vec3 vn[3];    // the shading normals at the vertices (smooth faces)
  uint8_t shadeLevel = 0;  // smooth faces: shaded over 4^level sub-triangles
  uint16_t material = 0;
  bool valid = false, flat = false;
};

struct ExactDirect::DirRegions {
  std::vector<uint8_t> state;         // per face: kHidden, kWhole, kPartial
  std::vector<uint32_t> partialFace;  // ascending
  std::vector<uint32_t> ringBegin;    // per partial face, + 1
  std::vector<uint32_t> ptBegin;      // per ring, + 1
  std::vector<cl::IntPoint> pts;
  std::vector<uint32_t> seen;  // faces not hidden, ascending

  void addPartial(uint32_t f, const cl::Paths& ps) {
    if (ringBegin.empty()) ringBegin.push_back(0), ptBegin.push_back(0);
    partialFace.push_back(f);
    for (const cl::Path& p : ps) {
      pts.insert(pts.end(), p.begin(), p.end());
      ptBegin.push_back(uint32_t(pts.size()));
    }
    ringBegin.push_back(uint32_t(ptBegin.size() - 1));
  }
  /// Partial face f's rings: ring r's points are pts[ptBegin[r] .. ptBegin[r + 1]) for r in
  /// [*r0, *r1) — read in place (no copy).
  void ringRange(uint32_t f, uint32_t* r0, uint32_t* r1) const {
    const auto it = std::lower_bound(partialFace.begin(), partialFace.end(), f);
    BTF_CHECK(it != partialFace.end() && *it == f);
    const size_t k = size_t(it - partialFace.begin());
    *r0 = ringBegin[k], *r1 = ringBegin[k + 1];
  }
  void paths(uint32_t f, cl::Paths* out) const {
    out->clear();
    const auto it = std::lower_bound(partialFace.begin(), partialFace.end(), f);
    BTF_CHECK(it != partialFace.end() && *it == f);
    const size_t k = size_t(it - partialFace.begin());
    for (uint32_t r = ringBegin[k]; r < ringBegin[k + 1]; ++r)
      out->emplace_back(pts.begin() + ptBegin[r], pts.begin() + ptBegin[r + 1]);
  }
  uint64_t bytes() const {
    return state.size() + 4 * (partialFace.size() + ringBegin.size() + ptBegin.size() +
                               seen.size()) +
           sizeof(cl::IntPoint) * pts.size();
  }
};

namespace {

// The intersection of two regions of one face (rings of a DirRegions each: outer rings
// counter-clockwise, holes clockwise), handed to emit(points, n, positive) as rings whose signed
// areas add up to the intersection's — over any cell, which is all the area raster needs. No
// polygon boolean: the region with fewer points is cut into the triangles of a fan per ring
// (a ring's winding number is the sum of its fan triangles', each signed by its orientation),
// and every ring of the other is clipped to each triangle by three half-planes (Sutherland–
// Hodgman keeps a ring's winding number inside a convex window, 0 outside). The rings handed on
// may hold zero-width parts along the window's sides; they add no area.
template <class Regions, class Band, class Emit>
void intersectInto(const Regions& RA, uint32_t a0, uint32_t a1, const Regions& RB, uint32_t b0,
                   uint32_t b1, Band&& meetsBand, Emit&& emit) {
  auto points = [](const Regions& R, uint32_t r0, uint32_t r1) {
    return size_t(R.ptBegin[r1] - R.ptBegin[r0]);
  };
  const bool swap = points(RA, a0, a1) < points(RB, b0, b1);
  const Regions& clipped = swap ? RB : RA;  // its rings are clipped
  const Regions& fan = swap ? RA : RB;      // its rings are cut into triangles
  const uint32_t c0 = swap ? b0 : a0, c1 = swap ? b1 : a1;
  const uint32_t f0 = swap ? a0 : b0, f1 = swap ? a1 : b1;
  thread_local std::vector<DRing> rings;
  thread_local std::vector<P2> poly, tmp;
  const size_t nr = c1 - c0;
  if (rings.size() < nr) rings.resize(nr);
  for (size_t k = 0; k < nr; ++k) {
    const uint32_t r = c0 + uint32_t(k);
    toRing(&clipped.pts[clipped.ptBegin[r]], clipped.ptBegin[r + 1] - clipped.ptBegin[r],
           &rings[k]);
  }
  for (uint32_t r = f0; r < f1; ++r) {
    const cl::IntPoint* q = &fan.pts[fan.ptBegin[r]];
    const size_t n = fan.ptBegin[r + 1] - fan.ptBegin[r];
    const P2 p0{double(q[0].X), double(q[0].Y)};
    for (size_t k = 1; k + 1 < n; ++k) {
      P2 t1{double(q[k].X), double(q[k].Y)}, t2{double(q[k + 1].X), double(q[k + 1].Y)};
      const double det = (t1.x - p0.x) * (t2.y - p0.y) - (t2.x - p0.x) * (t1.y - p0.y);
      if (det == 0) continue;  // no area
      if (det < 0) std::swap(t1, t2);
      const P2 t[3] = {p0, t1, t2};
      const double tx0 = std::min({p0.x, t1.x, t2.x}), tx1 = std::max({p0.x, t1.x, t2.x});
      const double ty0 = std::min({p0.y, t1.y, t2.y}), ty1 = std::max({p0.y, t1.y, t2.y});
      if (!meetsBand(t, 3)) continue;  // none of the rows evaluated
      for (size_t m = 0; m < nr; ++m) {
        const DRing& R = rings[m];
        if (R.x1 <= tx0 || R.x0 >= tx1 || R.y1 <= ty0 || R.y0 >= ty1) continue;
        const P2 box[4] = {{R.x0, R.y0}, {R.x1, R.y0}, {R.x0, R.y1}, {R.x1, R.y1}};
        if (!meetsBand(box, 4)) continue;
        poly = R.pts;
        for (int e = 0; e < 3 && poly.size() >= 3; ++e) {
          const P2& u = t[e];
          const P2& v = t[(e + 1) % 3];
          const double ea = -(v.y - u.y), eb = v.x - u.x;  // left of u → v: inside
          clipHalf(poly, ea, eb, -(ea * u.x + eb * u.y), &tmp);
          poly.swap(tmp);
        }
        if (poly.size() >= 3) emit(poly.data(), poly.size(), det > 0);
      }
    }
  }
}

}  // namespace

// A face seen from the view being evaluated: its map from local integers to the view's texel
// cells, and what its shading needs.
struct ExactDirect::ViewFace {
  uint32_t face;
  double cx[3], cy[3];  // cell x = cx0 + cx1·X + cx2·Y (X, Y the local integers); same for y
  double orient;        // ±1: the map's orientation (a face seen from its back flips)
  double y0, y1;        // the face's extent in cell rows (unwrapped)
  Vec3 ng, ns, wv;      // normals turned toward the viewer; the view
  Frame frame;
  Vec3 wo;
  const Material* mat;
  bool lambert;
  // Smooth faces: the vertices in cell coordinates, their shading normals (turned toward the
  // viewer), frames and the view in them.
  bool smooth = false;
  int level = 0;      // 4^level sub-triangles of (level+1)(level+2)/2… see subPoints
  uint32_t sub0 = 0;  // the first of its sub-grid's points in ViewFaces::subs
};

// A point of a smooth face's shading sub-grid seen from a view: local (integer-scaled)
// coordinates, cell coordinates, the shading normal turned toward the viewer and its frame.
struct ExactDirect::SubPoint {
  double X, Y, x, y;
  Vec3 ns, wo;
  Frame frame;
};

struct ExactDirect::ViewFaces {
  std::vector<ViewFace> faces;
  std::vector<SubPoint> subs;
  int width = 0;
};

namespace {
// The sub-grid of level k has n = 2^k steps along each edge; point (i, j), i + j ≤ n, at
// barycentric (i/n, j/n) is number idx(i, j) of (n + 1)(n + 2)/2.
inline int subIndex(int n, int i, int j) { return j * (n + 1) - j * (j - 1) / 2 + i; }
inline int subCount(int n) { return (n + 1) * (n + 2) / 2; }
}  // namespace

ExactDirect::ExactDirect(const TileGeometry& geom, const std::vector<Material>& materials,
                         const DirectionSet& dirs, int nu, int nv)
    : m_geom(geom), m_materials(materials), m_dirs(dirs), m_nu(nu), m_nv(nv) {
  BTF_CHECK(nu >= 1 && nv >= 1);
  const TriMesh& m = geom.mesh;
  m_faces.resize(m.tri.size());
  for (size_t t = 0; t < m.tri.size(); ++t) {
    Face& F = m_faces[t];
    const glm::uvec3& ix = m.tri[t];
    const DVec3 p0(m.pos[ix.x]), p1(m.pos[ix.y]), p2(m.pos[ix.z]);
    const DVec3 e1 = p1 - p0, e2 = p2 - p0;
    const DVec3 nn = glm::cross(e1, e2);
    const double len = glm::length(nn), l1 = glm::length(e1);
    F.diameter = std::max({l1, glm::length(e2), glm::length(p2 - p1)});
    F.material = t < geom.triMaterial.size() ? geom.triMaterial[t] : 0;
    // Zero-area (and numerically zero) triangles see and shade nothing, as in the tracer.
    F.valid = F.diameter > 0 && len > 1e-12 * F.diameter * F.diameter && l1 > 0 &&
              std::isfinite(len);
    if (!F.valid) continue;
    ++m_stats.faces;
    F.area = 0.5 * len;
    F.a0 = p0;
    F.n = nn / len;
    F.u = e1 / l1;
    F.v = glm::cross(F.n, F.u);
    F.loc[0] = {0, 0};
    F.loc[1] = {l1, 0};
    F.loc[2] = {glm::dot(e2, F.u), glm::dot(e2, F.v)};
    F.scale = kIntRange / F.diameter;
    for (const P2& p : F.loc)
      F.tri.push_back({cl::cInt(std::llround(p.x * F.scale)), cl::cInt(std::llround(p.y * F.scale))});
    // Flat: the three vertex normals agree, so the interpolated normal is one vector.
    const Vec3 na = m.nrm.empty() ? Vec3(0) : m.nrm[ix.x];
    const Vec3 nb = m.nrm.empty() ? Vec3(0) : m.nrm[ix.y];
    const Vec3 nc = m.nrm.empty() ? Vec3(0) : m.nrm[ix.z];
    auto same = [](const Vec3& a, const Vec3& b) {
      return std::abs(a.x - b.x) <= 1e-6f && std::abs(a.y - b.y) <= 1e-6f &&
             std::abs(a.z - b.z) <= 1e-6f;
    };
    F.flat = m.nrm.empty() || (same(na, nb) && same(na, nc));
    if (F.flat) {
      F.ns = geom.shadingNormal(uint32_t(t), 1.0f / 3, 1.0f / 3);
      ++m_stats.flatFaces;
    } else {
      F.vn[0] = geom.shadingNormal(uint32_t(t), 0, 0);
      F.vn[1] = geom.shadingNormal(uint32_t(t), 1, 0);
      F.vn[2] = geom.shadingNormal(uint32_t(t), 0, 1);
      // Split for shading until the normals of a sub-triangle's corners are ≲ kShadeAngle apart
      // (the planes' error falls as the square of that angle).
      const float c = std::min({glm::dot(F.vn[0], F.vn[1]), glm::dot(F.vn[1], F.vn[2]),
                                glm::dot(F.vn[0], F.vn[2])});
      const double spread = std::acos(std::clamp(double(c), -1.0, 1.0));
      while (F.shadeLevel < kMaxShadeLevel && spread > kShadeAngle * double(1 << F.shadeLevel))
        ++F.shadeLevel;
    }
  }
}

ExactDirect::~ExactDirect() = default;

bool ExactDirect::shades(uint32_t prim) const {
  return prim < m_faces.size() && m_faces[prim].valid && (m_faces[prim].flat || m_shadeSmooth);
}

std::vector<uint8_t> ExactDirect::shadedMask() const {
  std::vector<uint8_t> m(m_faces.size(), 0);
  for (size_t t = 0; t < m.size(); ++t) m[t] = shades(uint32_t(t)) ? 1 : 0;
  return m;
}

void ExactDirect::prepare(ProgressReporter* progress, const CancelToken* cancel) {
  const auto t0 = std::chrono::steady_clock::now();
  const int nD = m_dirs.size();
  m_regions.assign(size_t(nD), DirRegions{});
  std::vector<int64_t> tests(size_t(nD), 0);
  parallelForChunks(
      nD, 1,
      [&](int64_t b, int64_t e) {
        for (int64_t d = b; d < e; ++d) {
          hsr(int(d), &m_regions[size_t(d)], &tests[size_t(d)]);
          if (progress) progress->add(1);
        }
      },
      cancel);
  throwIfCancelled(cancel, "exact visibility");
  m_stats.partialRegions = 0;
  m_stats.occluderTests = 0;
  m_stats.regionBytes = 0;
  for (int d = 0; d < nD; ++d) {
    m_stats.partialRegions += int64_t(m_regions[size_t(d)].partialFace.size());
    m_stats.occluderTests += tests[size_t(d)];
    m_stats.regionBytes += m_regions[size_t(d)].bytes();
  }
  m_stats.hsrSeconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  m_prepared = true;
}

// The part of every face first seen from direction `dir` (a point at infinity along ω): face A
// loses, in its own plane, the parts where another triangle — or a periodic copy of any, its own
// included — lies in front of it along ω. Each such part is convex: A ∩ B's projection onto A's
// plane ∩ {B in front}; their union is removed by one Clipper difference.
void ExactDirect::hsr(int dir, DirRegions* out, int64_t* tests) const {
  const DVec3 w = m_dirs[dir].w;
  const double Lx = m_geom.Lx, Ly = m_geom.Ly;
  const size_t nF = m_faces.size();
  out->state.assign(nF, kHidden);
  const double sx = w.x / std::max(w.z, 1e-9), sy = w.y / std::max(w.z, 1e-9);
  // Projected bounding boxes on the reference plane along ω.
  struct Box {
    double x0, x1, y0, y1;
  };
  std::vector<Box> box(nF);
  std::vector<uint32_t> valid;
  for (uint32_t f = 0; f < nF; ++f) {
    if (!m_faces[f].valid) continue;
    valid.push_back(f);
    const glm::uvec3& ix = m_geom.mesh.tri[f];
    Box b{1e300, -1e300, 1e300, -1e300};
    for (uint32_t k : {ix.x, ix.y, ix.z}) {
      const DVec3 p(m_geom.mesh.pos[k]);
      const double qx = p.x - p.z * sx, qy = p.y - p.z * sy;
      b.x0 = std::min(b.x0, qx), b.x1 = std::max(b.x1, qx);
      b.y0 = std::min(b.y0, qy), b.y1 = std::max(b.y1, qy);
    }
    box[f] = b;
  }
  // A grid over one period holding every face whose box (wrapped) meets the cell.
  const int G = std::clamp(int(std::sqrt(double(valid.size())) / 2), 1, 64);
  const double cw = Lx / G, ch = Ly / G;
  auto cellRange = [&](double a0, double a1, double period, double size, int* c0, int* c1) {
    if (a1 - a0 >= period) {
      *c0 = 0, *c1 = G - 1;
      return;
    }
    *c0 = int(std::floor(a0 / size)), *c1 = int(std::floor(a1 / size));
  };
  auto wrapG = [&](int c) { return ((c % G) + G) % G; };
  std::vector<std::vector<uint32_t>> grid(size_t(G) * G);
  for (uint32_t f : valid) {
    int i0, i1, j0, j1;
    cellRange(box[f].x0, box[f].x1, Lx, cw, &i0, &i1);
    cellRange(box[f].y0, box[f].y1, Ly, ch, &j0, &j1);
    for (int j = j0; j <= j1 && j - j0 < G; ++j)
      for (int i = i0; i <= i1 && i - i0 < G; ++i)
        grid[size_t(wrapG(j)) * G + size_t(wrapG(i))].push_back(f);
  }
  std::vector<uint32_t> stamp(nF, UINT32_MAX);
  std::vector<uint32_t> cand;
  std::vector<P2> poly, tmp;
  cl::Paths occ, sol;
  const double tolW = 1e-9 * std::max(Lx, Ly);
  int64_t nTests = 0;
  for (uint32_t a : valid) {
    const Face& A = m_faces[a];
    if (!A.flat && !m_everyFace && !m_shadeSmooth) continue;  // an occluder only (sampled)
    const double nd = glm::dot(A.n, w);
    if (std::abs(nd) < 1e-6) continue;  // edge-on: no projected area
    const Box& ba = box[a];
    cand.clear();
    int i0, i1, j0, j1;
    cellRange(ba.x0, ba.x1, Lx, cw, &i0, &i1);
    cellRange(ba.y0, ba.y1, Ly, ch, &j0, &j1);
    for (int j = j0; j <= j1 && j - j0 < G; ++j)
      for (int i = i0; i <= i1 && i - i0 < G; ++i)
        for (uint32_t b : grid[size_t(wrapG(j)) * G + size_t(wrapG(i))])
          if (stamp[b] != a) stamp[b] = a, cand.push_back(b);
    std::sort(cand.begin(), cand.end());  // the same order whatever the grid: same bytes
    occ.clear();
    const double eps = 1e-12 * (Lx + Ly);
    for (uint32_t b : cand) {
      const Box& bb = box[b];
      const int k0 = int(std::floor((ba.x0 - bb.x1) / Lx)), k1 = int(std::ceil((ba.x1 - bb.x0) / Lx));
      const int m0 = int(std::floor((ba.y0 - bb.y1) / Ly)), m1 = int(std::ceil((ba.y1 - bb.y0) / Ly));
      const glm::uvec3& ix = m_geom.mesh.tri[b];
      for (int mm = m0; mm <= m1; ++mm)
        for (int kk = k0; kk <= k1; ++kk) {
          if (b == a && kk == 0 && mm == 0) continue;
          const double ox = kk * Lx, oy = mm * Ly;
          if (!(bb.x0 + ox < ba.x1 - eps && bb.x1 + ox > ba.x0 + eps)) continue;
          if (!(bb.y0 + oy < ba.y1 - eps && bb.y1 + oy > ba.y0 + eps)) continue;
          // B's copy projected along ω onto A's plane, in A's local frame; τ: how far in front.
          P2 q[3];
          double tau[3];
          double tmax = -1e300, tmin = 1e300;
          int k = 0;
          for (uint32_t vi : {ix.x, ix.y, ix.z}) {
            const DVec3 p = DVec3(m_geom.mesh.pos[vi]) + DVec3(ox, oy, 0);
            const double t = glm::dot(A.n, p - A.a0) / nd;
            const DVec3 r = p - t * w - A.a0;
            q[k] = {glm::dot(r, A.u), glm::dot(r, A.v)};
            tau[k] = t;
            tmax = std::max(tmax, t), tmin = std::min(tmin, t);
            ++k;
          }
          const bool coplanar = tmax <= tolW && tmin >= -tolW;
          // Behind A's plane (or on it, where the lower index wins the tie): no occlusion.
          if (coplanar ? b > a : tmax <= tolW) continue;
          const double det = (q[1].x - q[0].x) * (q[2].y - q[0].y) -
                             (q[2].x - q[0].x) * (q[1].y - q[0].y);
          if (!(std::abs(det) > 1e-14 * A.diameter * A.diameter)) continue;  // B edge-on to ω
          ++nTests;
          poly.assign(A.loc, A.loc + 3);
          const double s = det > 0 ? 1.0 : -1.0;
          for (int e = 0; e < 3 && poly.size() >= 3; ++e) {
            const P2& u = q[e];
            const P2& v = q[(e + 1) % 3];
            // Inside B': left of each edge of the counter-clockwise triangle.
            const double ea = -(v.y - u.y) * s, eb = (v.x - u.x) * s;
            clipHalf(poly, ea, eb, -(ea * u.x + eb * u.y), &tmp);
            poly.swap(tmp);
          }
          if (!coplanar && tmin < tolW && poly.size() >= 3) {
            // τ is affine over B': keep where τ > 0 (B in front).
            const double d1 = tau[1] - tau[0], d2 = tau[2] - tau[0];
            const double ga = (d1 * (q[2].y - q[0].y) - d2 * (q[1].y - q[0].y)) / det;
            const double gb = ((q[1].x - q[0].x) * d2 - (q[2].x - q[0].x) * d1) / det;
            const double gc = tau[0] - ga * q[0].x - gb * q[0].y;
            clipHalf(poly, ga, gb, gc, &tmp);
            poly.swap(tmp);
          }
          if (poly.size() < 3 || !(std::abs(polyArea(poly)) > 1e-14 * A.diameter * A.diameter))
            continue;
          cl::Path ip;
          ip.reserve(poly.size());
          const double lim = 2 * kIntRange;
          for (const P2& p : poly)
            ip.push_back({cl::cInt(std::llround(std::clamp(p.x * A.scale, -lim, lim))),
                          cl::cInt(std::llround(std::clamp(p.y * A.scale, -lim, lim)))});
          if (polyArea(poly) < 0) std::reverse(ip.begin(), ip.end());
          occ.push_back(std::move(ip));
        }
    }
    if (occ.empty()) {
      out->state[a] = kWhole;
      continue;
    }
    cl::Clipper c;
    c.AddPath(A.tri, cl::ptSubject, true);
    c.AddPaths(occ, cl::ptClip, true);
    execute(c, cl::ctDifference, &sol);
    const double full = cl::Area(A.tri), left = pathsArea(sol);
    if (!(left > 1e-9 * full)) continue;  // hidden
    if (left >= full * (1 - 1e-12)) {
      out->state[a] = kWhole;
      continue;
    }
    out->state[a] = kPartial;
    out->addPartial(a, sol);
  }
  for (uint32_t f = 0; f < nF; ++f)
    if (out->state[f] != kHidden) out->seen.push_back(f);
  *tests = nTests;
}

double ExactDirect::visibleFraction(int dir, uint32_t prim) const {
  BTF_CHECK(m_prepared && dir >= 0 && dir < m_dirs.size() && prim < m_faces.size());
  BTF_CHECK(m_everyFace || m_shadeSmooth || !m_faces[prim].valid || m_faces[prim].flat);
  const DirRegions& R = m_regions[size_t(dir)];
  if (R.state[prim] == kHidden) return 0;
  if (R.state[prim] == kWhole) return 1;
  cl::Paths ps;
  R.paths(prim, &ps);
  return pathsArea(ps) / cl::Area(m_faces[prim].tri);
}

void ExactDirect::prepareView(int view, ViewFaces* out) const {
  std::vector<ViewFace>* faces = &out->faces;
  faces->clear();
  out->subs.clear();
  const DVec3 w = m_dirs[view].w;
  const double sx = w.x / std::max(w.z, 1e-9), sy = w.y / std::max(w.z, 1e-9);
  const double kx = m_nu / m_geom.Lx, ky = m_nv / m_geom.Ly;
  double maxWidth = 0;
  for (uint32_t f : m_regions[size_t(view)].seen) {
    const Face& F = m_faces[f];
    if (!F.flat && !m_shadeSmooth) continue;
    ViewFace V;
    V.face = f;
    const double is = 1.0 / F.scale;
    // Cell coordinates of the local point (X, Y)/scale: a0 + X u + Y v projected along ω.
    V.cx[0] = kx * (F.a0.x - F.a0.z * sx);
    V.cx[1] = kx * (F.u.x - F.u.z * sx) * is;
    V.cx[2] = kx * (F.v.x - F.v.z * sx) * is;
    V.cy[0] = ky * (F.a0.y - F.a0.z * sy);
    V.cy[1] = ky * (F.u.y - F.u.z * sy) * is;
    V.cy[2] = ky * (F.v.y - F.v.z * sy) * is;
    const double det = V.cx[1] * V.cy[2] - V.cx[2] * V.cy[1];
    V.orient = det >= 0 ? 1.0 : -1.0;
    double x0 = 1e300, x1 = -1e300;
    for (const cl::IntPoint& p : F.tri) {
      const double x = V.cx[0] + V.cx[1] * double(p.X) + V.cx[2] * double(p.Y);
      x0 = std::min(x0, x), x1 = std::max(x1, x);
    }
    V.cx[0] -= std::floor(x0 / m_nu) * m_nu;  // whole periods: the face starts in [0, nu)
    V.y0 = 1e300, V.y1 = -1e300;
    for (const cl::IntPoint& p : F.tri) {
      const double y = V.cy[0] + V.cy[1] * double(p.X) + V.cy[2] * double(p.Y);
      V.y0 = std::min(V.y0, y), V.y1 = std::max(V.y1, y);
    }
    maxWidth = std::max(maxWidth, x1 - x0);
    V.wv = Vec3(w);
    const bool back = glm::dot(F.n, w) < 0;
    V.ng = back ? -Vec3(F.n) : Vec3(F.n);
    V.ns = back ? -F.ns : F.ns;
    V.mat = &m_materials[F.material];
    V.lambert = V.mat->type == BrdfType::Lambert;
    V.frame = Frame::fromNormal(V.ns);
    V.wo = V.frame.toLocal(V.wv);
    if (!F.flat) {
      V.smooth = true;
      V.level = F.shadeLevel;
      V.sub0 = uint32_t(out->subs.size());
      const int n = 1 << V.level;
      const double X0 = double(F.tri[0].X), Y0 = double(F.tri[0].Y);
      const double X1 = double(F.tri[1].X) - X0, Y1 = double(F.tri[1].Y) - Y0;
      const double X2 = double(F.tri[2].X) - X0, Y2 = double(F.tri[2].Y) - Y0;
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i + j <= n; ++i) {
          const float bu = float(i) / float(n), bv = float(j) / float(n);
          SubPoint P;
          P.X = X0 + X1 * (double(i) / n) + X2 * (double(j) / n);
          P.Y = Y0 + Y1 * (double(i) / n) + Y2 * (double(j) / n);
          P.x = V.cx[0] + V.cx[1] * P.X + V.cx[2] * P.Y;
          P.y = V.cy[0] + V.cy[1] * P.X + V.cy[2] * P.Y;
          // As TileGeometry::shadingNormal at (bu, bv).
          Vec3 nn = (1 - bu - bv) * F.vn[0] + bu * F.vn[1] + bv * F.vn[2];
          const float len = glm::length(nn);
          nn = len > 1e-12f ? nn / len : Vec3(F.n);
          P.ns = back ? -nn : nn;
          P.frame = Frame::fromNormal(P.ns);
          P.wo = P.frame.toLocal(V.wv);
          out->subs.push_back(P);
        }
    }
    faces->push_back(V);
  }
  out->width = m_nu + int(std::ceil(maxWidth)) + 3;
}

void ExactDirect::rasterLight(int view, int light, const ViewFaces& vf, int row0, int row1,
                              AreaRaster* raster) const {
  const std::vector<ViewFace>& faces = vf.faces;
  raster->reset(m_nu, m_nv, row0, row1, vf.width, m_shadeSmooth);
  thread_local std::vector<Rgb> subValue;
  thread_local std::vector<std::array<double, 18>> subLin;  // per sub-triangle ±(a, b, g) × 3
  thread_local std::vector<P2> subPoly, subTmp;
  thread_local std::vector<SubPoint> gathered;
  const Vec3 wl(m_dirs[light].w);
  const float invCos = float(1.0 / std::max(m_dirs[light].w.z, 1e-7));
  const DirRegions& RL = m_regions[size_t(light)];
  const DirRegions* RV = &m_regions[size_t(view)];
  cl::Paths pv, pl, sol;
  const bool allRows = row0 == 0 && row1 == m_nv;
  // Whether cell rows [y0, y1] (unwrapped) meet rows [row0, row1) wrapped: a chunk of texels
  // reads a band of the grid.
  auto rowsMet = [&](double y0, double y1) {
    if (allRows || y1 - y0 >= m_nv) return true;
    int r0 = int(std::floor(y0)) % m_nv;
    if (r0 < 0) r0 += m_nv;
    const int r1 = r0 + int(std::floor(y1) - std::floor(y0));  // inclusive, may pass nv
    return (r0 < row1 && r1 >= row0) || (r1 >= m_nv && r1 - m_nv >= row0);
  };
  for (const ViewFace& V : faces) {
    const uint8_t sl = RL.state[V.face];
    if (sl == kHidden) continue;
    if (!rowsMet(V.y0, V.y1)) continue;
    // Shading: a constant on a flat face; on a smooth one, over each of its 4^level
    // sub-triangles, the plane through the values at the corners (f_r · (n_s·ωi) / cos θi at
    // the interpolated shading normal, 0 where it turns from the light), a + b·x + g·y in cell
    // coordinates — second order in the sub-triangle's size.
    double wgt[3];  // the flat weight (smooth faces: subLin)
    int level = 0;  // smooth faces: the sub-grid used for this light
    const SubPoint* subP = nullptr;
    if (!V.smooth) {
      const float cosN = glm::dot(V.ns, wl), cn = glm::dot(V.ng, wl);
      if (cosN <= 0 || cn <= 0) continue;  // the light is on the other side
      if (!V.lambert && V.wo.z <= 0) continue;
      const Rgb f = V.lambert ? V.mat->kdOverPi : evalBrdf(*V.mat, V.frame.toLocal(wl), V.wo);
      const Rgb val = f * (cosN * invCos);
      if (!(val.x > 0 || val.y > 0 || val.z > 0)) continue;
      for (int c = 0; c < 3; ++c) wgt[c] = double(val[c]) * V.orient;
    } else {
      if (glm::dot(V.ng, wl) <= 0) continue;  // the face's back to the light
      const SubPoint* P = &vf.subs[V.sub0];
      auto value = [&](const SubPoint& q) {
        const float cosN = glm::dot(q.ns, wl);
        if (cosN <= 0 || (!V.lambert && q.wo.z <= 0)) return Rgb(0);
        const Rgb f = V.lambert ? V.mat->kdOverPi : evalBrdf(*V.mat, q.frame.toLocal(wl), q.wo);
        return f * (cosN * invCos);
      };
      // Split only where the face's values are not near a plane: the edges' midpoints off
      // their ends' mean by more than kShadeTolerance of the largest (or where the corners
      // differ in being lit; each test costs three evaluations).
      int n = 1 << V.level;
      if (n > 1) {
        const int h = n / 2;
        const int c[3] = {subIndex(n, 0, 0), subIndex(n, n, 0), subIndex(n, 0, n)};
        const int m[3] = {subIndex(n, h, 0), subIndex(n, h, h), subIndex(n, 0, h)};
        Rgb vc[3], vm[3];
        float top = 0, off = 0;
        for (int k = 0; k < 3; ++k) {
          vc[k] = value(P[c[k]]), vm[k] = value(P[m[k]]);
          top = std::max({top, vc[k].x, vc[k].y, vc[k].z, vm[k].x, vm[k].y, vm[k].z});
        }
        for (int k = 0; k < 3; ++k) {
          const Rgb d = vm[k] - 0.5f * (vc[k] + vc[(k + 1) % 3]);
          off = std::max({off, std::abs(d.x), std::abs(d.y), std::abs(d.z)});
        }
        if (!(top > 0)) continue;
        // A plane's error falls by 4 with each split: the fewest splits that bring the
        // midpoints' miss under the tolerance, up to the face's own level.
        int k = 0;
        for (float e = off; k < V.level && e > kShadeTolerance * top; e *= 0.25f) ++k;
        if (k < V.level) {
          const int stride = n >> k;
          n = 1 << k;
          gathered.clear();
          for (int j = 0; j <= n; ++j)
            for (int i = 0; i + j <= n; ++i)
              gathered.push_back(P[subIndex(1 << V.level, i * stride, j * stride)]);
          P = gathered.data();
        }
      }
      const int np = subCount(n);
      subValue.resize(size_t(np));
      bool any = false;
      for (int k = 0; k < np; ++k) {
        subValue[size_t(k)] = value(P[k]);
        const Rgb& v = subValue[size_t(k)];
        any = any || v.x > 0 || v.y > 0 || v.z > 0;
      }
      if (!any) continue;
      level = 0;
      while ((1 << level) < n) ++level;
      subP = P;
      // Each sub-triangle's plane: the upward ones (i, j), (i+1, j), (i, j+1), then the
      // downward ones (i+1, j), (i+1, j+1), (i, j+1).
      subLin.resize(size_t(n) * size_t(n));
      size_t t = 0;
      auto plane = [&](int ia, int ib, int ic) {
        const SubPoint &A = P[ia], &B = P[ib], &C = P[ic];
        const double x1 = B.x - A.x, y1 = B.y - A.y, x2 = C.x - A.x, y2 = C.y - A.y;
        const double det = x1 * y2 - x2 * y1;
        const double ext = std::max({std::abs(x1), std::abs(y1), std::abs(x2), std::abs(y2)});
        std::array<double, 18>& L = subLin[t++];
        for (int c = 0; c < 3; ++c) {
          const double va = subValue[size_t(ia)][c], d1 = subValue[size_t(ib)][c] - va,
                       d2 = subValue[size_t(ic)][c] - va;
          double b = 0, g = 0, a = va + (d1 + d2) / 3;
          // Nearly edge-on in projection: the mean (it adds next to no area).
          if (std::abs(det) > 1e-9 * ext * ext) {
            b = (d1 * y2 - d2 * y1) / det;
            g = (x1 * d2 - x2 * d1) / det;
            a = va - b * A.x - g * A.y;
          }
          const double abg[3] = {a, b, g};
          for (int q = 0; q < 3; ++q) {
            L[size_t(3 * q + c)] = abg[q] * V.orient;
            L[size_t(9 + 3 * q + c)] = -abg[q] * V.orient;
          }
        }
      };
      for (int j = 0; j < n; ++j)
        for (int i = 0; i + j < n; ++i)
          plane(subIndex(n, i, j), subIndex(n, i + 1, j), subIndex(n, i, j + 1));
      for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + j + 1 < n; ++i)
          plane(subIndex(n, i + 1, j), subIndex(n, i + 1, j + 1), subIndex(n, i, j + 1));
      wgt[0] = wgt[1] = wgt[2] = 0;
    }
    const double wneg[3] = {-wgt[0], -wgt[1], -wgt[2]};
    const Face& F = m_faces[V.face];
    auto px = [&](double X, double Y) { return V.cx[0] + V.cx[1] * X + V.cx[2] * Y; };
    auto py = [&](double X, double Y) { return V.cy[0] + V.cy[1] * X + V.cy[2] * Y; };
    // One ring (local integers or doubles) into the raster, projected onto the cells.
    // A ring's edges in cell coordinates, each handed to add(x0, y0, x1, y1).
    auto edges = [&](const auto* pts, size_t n, auto&& add) {
      double x0 = px(xOf(pts[n - 1]), yOf(pts[n - 1])), y0 = py(xOf(pts[n - 1]), yOf(pts[n - 1]));
      for (size_t i = 0; i < n; ++i) {
        const double x1 = px(xOf(pts[i]), yOf(pts[i])), y1 = py(xOf(pts[i]), yOf(pts[i]));
        add(x0, y0, x1, y1);
        x0 = x1, y0 = y1;
      }
    };
    auto emitFlat = [&](const auto* pts, size_t n, const double* w) {
      edges(pts, n, [&](double a, double b, double c, double d) { raster->addEdge(a, b, c, d, w); });
    };
    auto emitLinear = [&](const auto* pts, size_t n, const double* L) {
      edges(pts, n, [&](double a, double b, double c, double d) {
        raster->addLinearEdge(a, b, c, d, L, L + 3, L + 6);
      });
    };
    auto emit = [&](const auto* pts, size_t n, bool positive) {
      if (n < 3) return;
      if (!V.smooth) return emitFlat(pts, n, positive ? wgt : wneg);
      const int ns = 1 << level;
      if (ns == 1) return emitLinear(pts, n, subLin[0].data() + (positive ? 0 : 9));
      // The ring's part in each sub-triangle, shaded by that sub-triangle's plane.
      const SubPoint* P = subP;
      double rx0 = 1e300, rx1 = -1e300, ry0 = 1e300, ry1 = -1e300;
      for (size_t i = 0; i < n; ++i) {
        rx0 = std::min(rx0, xOf(pts[i])), rx1 = std::max(rx1, xOf(pts[i]));
        ry0 = std::min(ry0, yOf(pts[i])), ry1 = std::max(ry1, yOf(pts[i]));
      }
      size_t t = 0;
      auto piece = [&](int ia, int ib, int ic) {
        const double* L = subLin[t++].data() + (positive ? 0 : 9);
        const P2 T[3] = {{P[ia].X, P[ia].Y}, {P[ib].X, P[ib].Y}, {P[ic].X, P[ic].Y}};
        if (std::max({T[0].x, T[1].x, T[2].x}) <= rx0 || std::min({T[0].x, T[1].x, T[2].x}) >= rx1 ||
            std::max({T[0].y, T[1].y, T[2].y}) <= ry0 || std::min({T[0].y, T[1].y, T[2].y}) >= ry1)
          return;
        subPoly.resize(n);
        for (size_t i = 0; i < n; ++i) subPoly[i] = {xOf(pts[i]), yOf(pts[i])};
        for (int e = 0; e < 3 && subPoly.size() >= 3; ++e) {
          const P2& u = T[e];
          const P2& v = T[(e + 1) % 3];
          const double ea = -(v.y - u.y), eb = v.x - u.x;  // left of u → v: inside
          clipHalf(subPoly, ea, eb, -(ea * u.x + eb * u.y), &subTmp);
          subPoly.swap(subTmp);
        }
        if (subPoly.size() >= 3) emitLinear(subPoly.data(), subPoly.size(), L);
      };
      for (int j = 0; j < ns; ++j)
        for (int i = 0; i + j < ns; ++i)
          piece(subIndex(ns, i, j), subIndex(ns, i + 1, j), subIndex(ns, i, j + 1));
      for (int j = 0; j + 1 < ns; ++j)
        for (int i = 0; i + j + 1 < ns; ++i)
          piece(subIndex(ns, i + 1, j), subIndex(ns, i + 1, j + 1), subIndex(ns, i, j + 1));
    };
    const uint8_t sv = RV->state[V.face];
    uint32_t v0 = 0, v1 = 0, l0 = 0, l1 = 0;
    if (sv == kPartial) RV->ringRange(V.face, &v0, &v1);
    if (sl == kPartial) RL.ringRange(V.face, &l0, &l1);
    if (sv == kWhole && sl == kWhole) {
      emit(F.tri.data(), 3, true);
    } else if (sv == kWhole || sl == kWhole) {
      const DirRegions& R = sv == kWhole ? RL : *RV;
      for (uint32_t r = sv == kWhole ? l0 : v0, e = sv == kWhole ? l1 : v1; r < e; ++r)
        emit(&R.pts[R.ptBegin[r]], R.ptBegin[r + 1] - R.ptBegin[r], true);
    } else {
      // Pieces (of the face's local integers) wholly outside the band are left out.
      auto meetsBand = [&](const P2* p, int n) {
        if (allRows) return true;
        double y0 = 1e300, y1 = -1e300;
        for (int k = 0; k < n; ++k) {
          const double y = py(p[k].x, p[k].y);
          y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
        return rowsMet(y0, y1);
      };
      intersectInto(*RV, v0, v1, RL, l0, l1, meetsBand, emit);
    }
  }
  raster->resolve();
}

void ExactDirect::setRowCache(uint64_t bytes) {
  const uint64_t rowBytes = uint64_t(m_dirs.size()) * uint64_t(m_dirs.size()) *
                            uint64_t(m_nu) * 3 * sizeof(float);  // one row of every view
  m_blockRows = int(std::min<uint64_t>(uint64_t(m_nv), bytes / rowBytes));
  m_rowBlocks.clear();
  if (m_blockRows < 2) {
    m_blockRows = 0;
    return;
  }
  for (int v = 0; v < m_dirs.size(); ++v) m_rowBlocks.push_back(std::make_unique<RowBlock>());
}

void ExactDirect::evalView(int view, int64_t t0, int64_t t1, float* out,
                           size_t texelStride) const {
  BTF_CHECK(m_prepared && view >= 0 && view < m_dirs.size());
  BTF_CHECK(t0 >= 0 && t1 <= int64_t(m_nu) * m_nv && t0 < t1);
  const int row0 = int(t0 / m_nu), row1 = int((t1 - 1) / m_nu) + 1;
  if (m_blockRows <= row1 - row0) {
    evalRows(view, t0, t1, out, texelStride);
    return;
  }
  RowBlock& B = *m_rowBlocks[size_t(view)];
  const size_t nL3 = size_t(m_dirs.size()) * 3;
  std::lock_guard<std::mutex> hold(B.lock);
  if (!(B.r0 <= row0 && row1 <= B.r1)) {
    B.r0 = row0, B.r1 = std::min(m_nv, row0 + m_blockRows);
    B.values.resize(size_t(B.r1 - B.r0) * size_t(m_nu) * nL3);
    evalRows(view, int64_t(B.r0) * m_nu, int64_t(B.r1) * m_nu, B.values.data(), nL3);
  }
  const int64_t base = int64_t(B.r0) * m_nu;
  for (int64_t t = t0; t < t1; ++t)
    std::copy_n(&B.values[size_t(t - base) * nL3], nL3, out + size_t(t - t0) * texelStride);
}

void ExactDirect::evalRows(int view, int64_t t0, int64_t t1, float* out,
                           size_t texelStride) const {
  const int row0 = int(t0 / m_nu), row1 = int((t1 - 1) / m_nu) + 1;
  thread_local ViewFaces faces;
  thread_local AreaRaster raster;
  prepareView(view, &faces);
  for (int l = 0, nL = m_dirs.size(); l < nL; ++l) {
    rasterLight(view, l, faces, row0, row1, &raster);
    for (int64_t t = t0; t < t1; ++t) {
      const int i = int(t % m_nu), j = int(t / m_nu);
      float* o = out + size_t(t - t0) * texelStride + 3 * size_t(l);
      for (int c = 0; c < 3; ++c) {
        const double v = raster.value(i, j, c);
        // Rounding leaves −1e-17 where a texel sees nothing; NaN never reaches a file.
        o[c] = std::isfinite(v) && v > 0 ? float(v) : 0.0f;
      }
    }
  }
}

void ExactDirect::evalViewTexels(int view, const int64_t* texels, size_t n,
                                 float* const* rows) const {
  BTF_CHECK(m_prepared && view >= 0 && view < m_dirs.size());
  if (n == 0) return;
  const int64_t all = int64_t(m_nu) * m_nv;
  // The runs of consecutive rows that hold a requested texel.
  std::vector<uint8_t> wanted(size_t(m_nv), 0);
  for (size_t k = 0; k < n; ++k) {
    BTF_CHECK(texels[k] >= 0 && texels[k] < all);
    wanted[size_t(texels[k] / m_nu)] = 1;
  }
  std::vector<std::pair<int, int>> runs;
  for (int j = 0; j < m_nv; ++j)
    if (wanted[size_t(j)]) {
      if (!runs.empty() && runs.back().second == j)
        runs.back().second = j + 1;
      else
        runs.push_back({j, j + 1});
    }
  thread_local ViewFaces faces;
  thread_local AreaRaster raster;
  prepareView(view, &faces);
  for (int l = 0, nL = m_dirs.size(); l < nL; ++l)
    for (const auto& [row0, row1] : runs) {
      rasterLight(view, l, faces, row0, row1, &raster);
      for (size_t k = 0; k < n; ++k) {
        const int i = int(texels[k] % m_nu), j = int(texels[k] / m_nu);
        if (j < row0 || j >= row1) continue;
        for (int c = 0; c < 3; ++c) {
          const double v = raster.value(i, j, c);
          rows[k][3 * size_t(l) + size_t(c)] = std::isfinite(v) && v > 0 ? float(v) : 0.0f;
        }
      }
    }
}

void ExactDirect::evalPair(int view, int light, float* image) const {
  BTF_CHECK(m_prepared && view >= 0 && view < m_dirs.size() && light >= 0 &&
            light < m_dirs.size());
  ViewFaces faces;
  AreaRaster raster;
  prepareView(view, &faces);
  rasterLight(view, light, faces, 0, m_nv, &raster);
  for (int j = 0; j < m_nv; ++j)
    for (int i = 0; i < m_nu; ++i)
      for (int c = 0; c < 3; ++c) {
        const double v = raster.value(i, j, c);
        image[3 * (size_t(j) * m_nu + size_t(i)) + size_t(c)] =
            std::isfinite(v) && v > 0 ? float(v) : 0.0f;
      }
}

}  // namespace btf
