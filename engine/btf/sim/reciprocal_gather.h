// The reciprocal gather (issue 36): the network's final gather is sharp on the view side only —
// each hit the camera sees measures its own occlusion and takes its neighbours' irradiance,
// while the light side stays at the network's resolution — so its tile-averaged indirect light
// at (view v, light l) and at (l, v) differ (V-grooves, bonn81: 2.6 % of the total at grazing
// pairs). Both estimate the same quantity: every order of scattering obeys Helmholtz
// reciprocity, so the tile average of the indirect aBRDF I(v, l) equals I(l, v). The gather's
// tile sums are computed exactly, for every pair, from the hit maps' samples (the hits the
// final gather itself visits), and each pair's gathered light is scaled by
//   s(v, l) = ½ (I(v, l) + I(l, v)) / I(v, l)   (per channel, clamped to [½, 2]),
// which leaves the per-texel shape of the view-side gather and makes its tile average the mean
// of the two estimates: reciprocal by construction, and never further from the truth than the
// two one-sided estimates' RMS (the mean of two estimates of one value).
#pragma once
#include <btf/core/comm.h>
#include <btf/core/parallel.h>
#include <btf/core/progress.h>
#include <btf/sim/hit_maps.h>
#include <btf/sim/network.h>

#include <vector>

namespace btf {

/// The final gather's tile sums over every sample of the hit maps, per (view, light, channel):
/// I[(v · nL + l) · 3 + c] (each sample weighted 1 / spp², as the texel kernel does). A cluster
/// job splits the views over its ranks and every rank gets all (the same values for any rank
/// or thread count: each view is summed by one task, in sample order). With `occlusion`, the
/// occluded fraction each sample's hit measured is kept for NetworkGather::setOcclusionCache
/// (views × samples counts, 255 where not measured: a hit without neighbours), every rank's
/// views on every rank, so that the texels' gather, which visits the same hits, traces no ray
/// again.
std::vector<double> gatherTileSums(const NetworkGather& gather, const HitMaps& maps,
                                   const TileGeometry& geom, const DirectionSet& dirs,
                                   Comm& comm, ProgressReporter* progress = nullptr,
                                   const CancelToken* cancel = nullptr,
                                   std::vector<uint8_t>* occlusion = nullptr);

struct ReciprocalScale {
  std::vector<float> scale;  // views × lights × 3
  double maxCorrection = 0;  // the largest |s − 1| applied (a channel above 1e-6 of the largest)
  int clamped = 0;           // (pair, channel)s held at ½ or 2
};
/// s(v, l) from the tile sums of an n-direction set (views = lights).
ReciprocalScale reciprocalScale(const std::vector<double>& sums, int n);

}  // namespace btf
