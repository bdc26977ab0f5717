// Multi-resolution BTFs (docs/mip.md; thesis §4.4.2): the texel levels of a BTF built by box
// averaging (store/levels.h), compressed together as one pyramid by any codec (the levels' texels
// one after the other, clustered and factorised together), and opened level by level behind the
// Decoder API.
#pragma once
#include <btf/compress/compress.h>
#include <btf/store/levels.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace btf {

/// Level `to` (coarser) from the level above it: `fineRow(v)` gives fine row v (nu texels of
/// `stride` floats); out receives mu × mv texels. Each value is Σ w·x in double, rounded once.
void downsampleLevel(const std::function<const float*(int)>& fineRow, int nu, int nv, size_t stride,
                     int mu, int mv, float* out, const CancelToken* cancel = nullptr);

/// Levels 1..upTo of a BTF read through a decoder (texel() per texel; a raw store's chunks are
/// verified on the way), concatenated in pyramid order from level 1. Holds at most three rows of
/// level 0 and the coarse levels themselves.
std::vector<float> buildCoarseLevels(const Decoder& base, int upTo, bool progress,
                                     const CancelToken* cancel = nullptr);
/// Same from values already in memory (level 0, texel-major).
std::vector<float> buildCoarseLevels(const float* base, const BtfInfo& info, int upTo,
                                     const CancelToken* cancel = nullptr);

/// Visibility-map levels: for each direction, a coarse texel's coverage is the largest of its
/// box's and its height the highest of its covered texels' — never less relief than any texel
/// it stands for, so silhouettes drawn from a coarse level are never smaller. `vmf`: nDirs ×
/// nu × nv × (coverage, height); returns levels 1..upTo likewise, direction-major per level.
std::vector<std::vector<float>> vmfLevels(const std::vector<float>& vmf, int nDirs, int nu, int nv,
                                          int upTo);

/// The geometry a codec sees for a pyramid: the levels' texels as one strip (nu = all of them,
/// nv = 1), the rest of the base's header kept.
BtfInfo pyramidInfo(const BtfInfo& base);
/// A pyramid file as the one strip of texels its codec coded (pyramidInfo, no levels): what
/// its codec's decoder and GPU tables read.
CompressedBtf asStrip(CompressedBtf pyramid);

/// `base` with level k's texel grid.
BtfInfo levelInfo(const BtfInfo& base, const MipLevel& level);

/// Level `level` of a decoder that decodes a pyramid strip (pyramidInfo), presented with the
/// level's own geometry.
std::unique_ptr<Decoder> pyramidLevel(std::shared_ptr<const Decoder> strip, const BtfInfo& base,
                                      int level);
/// Level `level` of a pyramid file (c.levels non-empty); makeDecoder(c) is its level 0.
std::unique_ptr<Decoder> makePyramidDecoder(CompressedBtf c, int level);

/// Level `level` of a BTF file: a pyramid .cbtf decodes its own; a raw store or a single-level
/// .cbtf box-filters it from level 0 (in memory, refused past memoryBudget). Level 0 is
/// openBtf(path). btf::Error names the level range.
std::unique_ptr<Decoder> openBtfLevel(const std::string& path, int level, uint64_t memoryBudget = 0,
                                      bool progress = false, const CancelToken* cancel = nullptr);

/// The footprint rule shared by the CPU renderer and the GLSL decoder (docs/mip.md): a pixel
/// sample's footprint, axes of lengths la, lb in level-0 texels, is covered by na × nb taps at its
/// cells' centres (na along the first axis) — the short axis cut in up to two cells (one under two
/// texels), the long one in cells as wide, at most maxAniso times as many — each read at lod =
/// log2(cell width), clamped to [0, levels − 1]. Within one texel: a single tap.
struct TexelFilter {
  double lod = 0;
  int na = 1, nb = 1;
};
TexelFilter texelFilter(double la, double lb, int maxAniso, int levels);

/// What the GLSL decodeFiltered computes, on the CPU: (x, y) and the footprint axes a, b in
/// level-0 texels, `levels` the decoders of every level (level 0 first); each tap reads the two
/// levels around lod bilinearly (Decoder::evaluateAt) and blends them.
std::array<float, 3> evaluateFiltered(const std::vector<const Decoder*>& levels, double x, double y,
                                      const double a[2], const double b[2], int maxAniso,
                                      double thetaI, double phiI, double thetaO, double phiO,
                                      double* lod = nullptr);

struct PyramidReport : CompressReport {
  double levelSeconds = 0;  // building levels 1..
  struct Level {
    int nu = 0, nv = 0;
    double relRmse = 0, rmse = 0;
  };
  std::vector<Level> levels;
};

/// `compress --mip`: the raw store's levels built (in memory: a third of the raw bytes, checked
/// against the budget), every level's texels encoded as one pyramid by the codec of `s` (its
/// target ratio or error applies to the pyramid's raw bytes), each level's error measured.
CompressedBtf compressPyramid(const std::string& inPath, const CodecSettings& s, bool progress,
                              const CancelToken* cancel, PyramidReport* report);

}  // namespace btf
