// Exports to formats users' tools read (docs/exports.md; facts from ../shared/FORMATS.md):
// the Bonn UBO2003/UTIA image set, the UBO2014 DFMF `.btf` container and MERL's isotropic
// `.binary`. Every export decodes through the Decoder API, so raw and compressed BTFs export
// alike.
#pragma once
#include <btf/compress/codec.h>

#include <array>
#include <string>
#include <vector>

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

/// The tile-averaged aBRDF as an RGL measured-BSDF tensor file (docs/exports.md; Dupuy & Jakob
/// 2018's format, read by Mitsuba 3's and pbrt-v4's `measured` BSDF). Parameterised by the view
/// (θ_i, φ_i: `thetaI` elevations in [0, 89°], `phiI` azimuths over [−π, π], anisotropic) and
/// the half vector in Dupuy & Jakob's unit square (θ_m = u²·π/2, φ_m = (2v − 1)·π) on a
/// `resolution`² grid; `rgb` holds aBRDF(light = reflect(view, m), view) · cos θ_light there
/// (jacobian = 0), `luminance` its luminance (the sampling density), `vndf` a uniform warp
/// (the half-vector grid is the parameterisation), `ndf` and `sigma` the micro-geometry's own
/// normal distribution and projected area from the tile's facets (area-weighted, upper
/// hemisphere), so that a reader may use them.
struct RglOptions {
  int thetaI = 16, phiI = 33, resolution = 48, ndfResolution = 64, sigmaResolution = 32;
};
struct RglReport {
  uint64_t bytes = 0;
  int thetaI = 0, phiI = 0, resolution = 0;
  double ndfProjectedArea = 0;  // ∫ D(m) cos θ_m dω_m over the upper hemisphere (1: a height field)
  double facets = 0;            // facets that face up
};
/// `facets`: the tile's triangles (face normal n_f, area A_f: each n·A in `areaNormals`) over a
/// tile of area `tileArea`.
RglReport exportRglBsdf(const Decoder& d, const std::vector<std::array<double, 3>>& areaNormals,
                        double tileArea, const std::string& file, const std::string& description,
                        const CancelToken* cancel = nullptr, const RglOptions& o = {});

/// FILE.partial written then renamed onto FILE.
void writeFileAtomic(const std::string& path, const std::string& bytes);

/// Bin centre of MERL indices → (θh, θd, φd) in radians, and (θh, θd, φd, φh) → (ω_i, ω_o).
void merlBinCentre(int thetaHalf, int thetaDiff, int phiDiff, double* th, double* td, double* pd);
void halfDiffToDirections(double th, double ph, double td, double pd, double wi[3], double wo[3]);

}  // namespace btf
