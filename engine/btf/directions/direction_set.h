// Direction sets shared by view and light (§4.2.1): regular θ×φ grids, the Bonn UBO2003 81-set
// and the UBO2014 151-set. All are "ring" sets: rings of constant θ with equally spaced φ.
// Conventions: θ from +z, φ from +x counter-clockwise; angles stored in radians.
#pragma once
#include <btf/core/math.h>

#include <array>
#include <string>
#include <vector>

namespace btf {

struct Direction {
  double theta = 0, phi = 0;  // radians
  DVec3 w{0, 0, 1};           // unit vector (sinθ cosφ, sinθ sinφ, cosθ)
  double solidAngle = 0;      // weight: the solid angle of its cell; they sum to 2π
};

struct DirectionRing {
  double theta = 0;      // radians
  int count = 1;         // azimuths
  double phiOffset = 0;  // radians
  int first = 0;         // index of its first direction in the set
};

/// A weighted direction for interpolation.
struct DirWeight {
  int index = 0;
  double weight = 0;
};

class DirectionSet {
 public:
  /// Regular grid: nθ rings at cell centres θ_k = (k + ½)·90°/nθ, each with nφ azimuths at
  /// φ_j = (j + ½)·360°/nφ. Cells are the θ×φ rectangles around them.
  static DirectionSet grid(int nTheta, int nPhi);
  /// "NθxNφa": the pole plus Nθ − 1 rings at k·90°/Nθ, Nφ azimuths from φ = 0 (a multiple of 4,
  /// so the axes φ = 0°, 90°, 180°, 270° are directions). Interpolated ring-linearly.
  static DirectionSet axisGrid(int nTheta, int nPhi);
  static DirectionSet bonn81();
  static DirectionSet ubo151();
  /// "bonn81", "ubo151", "16x32" (θ×φ grid) or "grid:16x32". Throws btf::Error naming the text.
  static DirectionSet fromName(const std::string& name);
  /// Rings given explicitly (θ in degrees, count, φ offset in degrees).
  static DirectionSet fromRings(const std::string& name,
                                const std::vector<std::array<double, 3>>& ringsDeg);

  /// The given directions verbatim (angles, vectors and weights copied bit for bit), each its own
  /// ring: what a preview of a few directions of a set traces. Not meant for interpolate().
  static DirectionSet subset(const std::string& name, const std::vector<Direction>& dirs);
  const std::string& name() const { return m_name; }
  int size() const { return int(m_dirs.size()); }
  const Direction& operator[](int i) const { return m_dirs[size_t(i)]; }
  const std::vector<Direction>& dirs() const { return m_dirs; }
  const std::vector<DirectionRing>& rings() const { return m_rings; }
  bool isGrid() const { return m_grid; }

  /// Index of the direction with the largest dot product with w.
  int nearest(const DVec3& w) const;
  /// Up to four directions and weights (summing to 1) that interpolate at (θ, φ): linear in θ
  /// between the two bracketing rings, linear in φ inside each ring (wrapping), clamped beyond
  /// the first and last ring. On a grid this is bilinear interpolation on the θ×φ cells.
  std::vector<DirWeight> interpolate(double theta, double phi) const;
  /// The same into `out` without allocating (renderers call it per sample); returns the count.
  int interpolate(double theta, double phi, DirWeight out[4]) const;

 private:
  void finish(bool gridCells);
  std::string m_name;
  std::vector<DirectionRing> m_rings;
  std::vector<Direction> m_dirs;
  bool m_grid = false;
};

}  // namespace btf
