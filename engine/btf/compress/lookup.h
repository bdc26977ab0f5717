// Reading a BTF from outside a renderer (the Python package, `btfsim slice`): batched aBRDF
// lookups at any tile position and any pair of directions, a spatial slice at one (view, light)
// pair, and the tile-averaged matrix — each computed once here, so that every front door gives
// the same numbers (docs/python.md).
#pragma once
#include <btf/compress/codec.h>
#include <btf/core/parallel.h>

#include <cstddef>
#include <vector>

namespace btf {

/// n lookups: uv[2k..2k+1] the position in the tile (fractions of it, periodic: texel centres at
/// (i + ½)/nu), wi[3k..] the light and wo[3k..] the view as unit vectors of the tile's frame (z
/// up, φ = atan2(y, x)). out[3k..] receives the aBRDF (1/sr, linear RGB): bilinear between the
/// four nearest texels, interpolated between the set's directions as Decoder::evaluateAt does
/// (the same values); 0 where either direction is at or below the horizon or not finite. A
/// continuous decoder (Decoder::continuous(): the neural codec) is evaluated at the pair itself
/// instead, as `btfsim render` reads it.
void evaluateBatch(const Decoder& d, size_t n, const double* uv, const double* wi, const double* wo,
                   float* out, const CancelToken* cancel = nullptr);

/// The same over every value of the BTF in memory (allValues): what batched lookups from Python
/// and Mitsuba use, tens of times faster than a decoder's one value at a time.
void evaluateBatch(const BtfInfo& info, const float* values, size_t n, const double* uv,
                   const double* wi, const double* wo, float* out,
                   const CancelToken* cancel = nullptr);
/// Every value, texel-major: [(t · n + view) · n + light] · 3 + c (texels() · n² · 3 floats).
std::vector<float> allValues(const Decoder& d, const CancelToken* cancel = nullptr);

/// The nu × nv image of aBRDF values at view (θv, φv) and light (θl, φl), radians, interpolated
/// between the set's directions (a continuous decoder, the neural codec: its own value at the pair
/// itself); rows bottom first (v up), RGB: what `btfsim slice --view` writes (writeRgbImage flips
/// it to the file's top-first order).
std::vector<float> spatialSlice(const Decoder& d, double thetaV, double phiV, double thetaL,
                                double phiL, const CancelToken* cancel = nullptr);

/// The tile average of every (view, light) value: out[(view · n + light) · 3 + c].
std::vector<float> tileAverage(const Decoder& d, const CancelToken* cancel = nullptr);

}  // namespace btf
