// The adaptive texel sampler's working state (adaptive.cpp): a sample of the texel, and the
// per-thread scratch of one (texel, view) — its levels of samples, the faces it sees and their
// unshadowed values per light, the lit and shadow-edge flags per light, and the cells of the
// geometric and per-light refinements — with the grid helpers the refinement walks them by.
// Not part of the engine's public surface.
#pragma once
#include <btf/sim/adaptive.h>

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace btf::adaptivedetail {

struct Sample {
  DVec3 pos;     // on the reference plane
  float lx = 0;  // position inside the texel, in [0, 1)
  float ly = 0;
  bool ok = false;      // the camera ray hit a shadeable surface
  bool inPrev = false;  // already part of the previous level (its contributions are summed)
  int cls = -1;         // its face in Scratch::faces (−1: none, its value is its own)
  int prevIndex = -1;   // its index in the previous level's array
  int64_t si = -1;      // its hit-map sample (−1: a refined sample of its own)
  DirectIllumination::Surface s;
};

constexpr int kMaxClasses = 16;  // faces per (texel, view) whose values are shared

struct Scratch {
  std::vector<Sample> levels[AdaptiveStats::kLevels];
  // The faces seen in the current (texel, view) — material and normals — and, per face and
  // light, the unshadowed value (valid where its stamp is the current one).
  struct Face {
    uint32_t material;
    Vec3 n, ng;
    DirectIllumination::Surface s;  // one of its samples
  };
  std::vector<Face> faces;
  std::vector<Rgb> classValue;
  std::vector<uint32_t> classStamp;
  uint32_t stamp = 0;
  std::vector<uint8_t> lit;     // per light: every receiver of the texel is lit
  std::vector<uint8_t> notLit;  // per light: a sample was shadowed, or the map undecided
  std::vector<int8_t> cellEdge[AdaptiveStats::kLevels];  // per level and cell: −1 unknown
  // The geometric refinement: per level, the cells whose children exist; the current level's
  // representative sample of each cell and whether the cell has its own sample.
  std::vector<uint8_t> built[AdaptiveStats::kLevels];
  std::vector<const Sample*> rep, nextRep;
  std::vector<uint8_t> exists, nextExists;
  std::vector<float> area;                    // per face: cells of the final grid
  std::vector<std::array<int, 2>> geoExtra;   // (level, cell): its samples beyond the map's
  std::vector<std::array<int, 3>> facePairs;  // (face a, face b, neighbouring cell pairs)
  // Per active light (slot) and cell of the current level: luminance, RGB, own sample or not.
  std::vector<float> cellY, nextY;
  std::vector<Rgb> cellRgb, nextRgb;
  std::vector<uint8_t> cellReal, nextReal, split, made, kept, hot;
  std::vector<int> samplesUsed, finalLevel, keep;
  std::vector<float> err;        // per light: error estimate of its last level
  std::vector<uint8_t> flagged;  // per light: the quadrants whose footprint holds a shadow edge
  // Per light: the faces (bits 0..15; bit 16: no hit) lit wherever they lie in the texel.
  std::vector<uint32_t> certified;
  // Per face: the plane of its samples (offset along its geometric normal), or none.
  std::vector<float> faceOffset;
  std::vector<uint8_t> facePlanar;
  std::vector<float> faceLo, faceHi;
  // Per level up to the face refinement's and cell: the faces its leaves see (bits as above).
  std::vector<uint32_t> cellFaces[AdaptiveStats::kLevels];
  // Per active light (slot) and cell: the face of the cell's sample (−1: none, −2: unclassified).
  std::vector<int8_t> cellFace, nextFace;
  // Per cell of the face refinement: the level of the cell its sample covers; likewise per
  // active light and cell.
  std::vector<int8_t> repLevel, nextRepLevel, cellLevel, nextLevel;
  std::vector<std::pair<const Sample*, Rgb>> merged;
  std::vector<int> active, next;
};

// Calls f(k, o) for every pair of horizontally or vertically neighbouring cells of a K×K grid.
template <class F>
void forNeighbourPairs(int K, F f) {
  for (int r = 0; r < K; ++r)
    for (int c = 0; c < K; ++c) {
      const int k = r * K + c;
      if (c + 1 < K) f(k, k + 1);
      if (r + 1 < K) f(k, k + K);
    }
}

// Cell (c, r) of a K×K grid, or one of its four neighbours, is hot.
inline bool hotOrNeighbour(const std::vector<uint8_t>& hot, int K, int c, int r) {
  const size_t k = size_t(r) * K + size_t(c);
  return hot[k] || (c > 0 && hot[k - 1]) || (c + 1 < K && hot[k + 1]) ||
         (r > 0 && hot[k - size_t(K)]) || (r + 1 < K && hot[k + size_t(K)]);
}

inline float lum(const Rgb& c) {
  return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
}

}  // namespace btf::adaptivedetail
