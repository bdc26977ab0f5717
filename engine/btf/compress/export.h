// Exports to formats users' tools read (docs/exports.md; facts from ../shared/FORMATS.md):
// the Bonn UBO2003/UTIA image set, the UBO2014 DFMF `.btf` container and MERL's isotropic
// `.binary`. Every export decodes through the Decoder API, so raw and compressed BTFs export
// alike.
#pragma once
#include <btf/compress/codec.h>

#include <string>

namespace btf {

struct Ubo2003Options {
  std::string imageFormat = "exr";  // exr (linear float), png or jpg (8-bit sRGB)
  bool zip = false;                 // one .zip file instead of a folder (what PyPI readers open)
  double scale = 0;                 // png/jpg: aBRDF × scale → [0, 1] before sRGB (0 = 1 / peak)
};
struct Ubo2003Report {
  int64_t images = 0;
  double scale = 1;    // png/jpg: the scale used (stated in btf_export.json)
  double clipped = 0;  // png/jpg: fraction of values above 1 after scaling (clamped)
};
/// One image per (light, view) pair, in one folder per view:
/// OUT/tvTTT_pvPPP/tlTTT_plPPP_tvTTT_pvPPP.EXT (integer degrees), plus OUT/btf_export.json saying
/// what the values are. With `zip`, the same entries in one archive OUT (written as OUT.partial,
/// then renamed; images stored, not deflated).
Ubo2003Report exportUbo2003(const Decoder& d, const std::string& out, bool progress,
                            const CancelToken* cancel = nullptr, const Ubo2003Options& o = {});

struct Ubo2014Report {
  int components[3] = {0, 0, 0};
  double relRmse = 0;       // of the rank-C factorisation against the source (training texels)
  double measuredRmse = 0;  // the stored fp16 factors against the source, every texel
  uint64_t bytes = 0;
};
/// DFMF container, colour model 0 (RGB), fp16, full-matrix SVD of the decoded BTF with C
/// components per channel, or (components = 0) as many as keep the factorisation's relative
/// RMSE against its source at most targetRmse (spectra of the training texels).
Ubo2014Report exportUbo2014(const Decoder& d, const std::string& file, int components,
                            bool progress, const CancelToken* cancel = nullptr,
                            double targetRmse = 0.01);

struct MerlReport {
  int64_t bins = 0, missingBins = 0;
  double anisotropy = 0;  // mean relative spread of the aBRDF over φ_h (0 for isotropic data)
  // Helmholtz reciprocity of the source: Σ|f(ωi, ωo) − f(ωo, ωi)| / Σ(f(ωi, ωo) + f(ωo, ωi))·2
  // over every sample (luminance), and the largest bin's relative difference.
  double asymmetry = 0, asymmetryMax = 0;
};
/// Texel-averaged aBRDF resampled to MERL's 90 × 90 × 180 bins: each bin's value is the mean
/// over phiSamples half-vector azimuths φ_h = (k + ½)·2π/phiSamples at the bin centre of the
/// symmetrised ½(f(ωi, ωo) + f(ωo, ωi)) (MERL's data are reciprocal; the source's asymmetry
/// is measured and reported); bins with every sample below the horizon are missing (−1).
MerlReport exportMerl(const Decoder& d, const std::string& file, int phiSamples, bool progress,
                      const CancelToken* cancel = nullptr);

/// Bin centre of MERL indices → (θh, θd, φd) in radians, and (θh, θd, φd, φh) → (ω_i, ω_o).
void merlBinCentre(int thetaHalf, int thetaDiff, int phiDiff, double* th, double* td, double* pd);
void halfDiffToDirections(double th, double ph, double td, double pd, double wi[3], double wo[3]);

}  // namespace btf
