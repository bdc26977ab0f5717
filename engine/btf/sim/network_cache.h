// Point networks built recently in this process, for reuse. A network is a pure function of the
// tile's geometry and its settings (density, links, α directions, seed), not of the texels, the
// samples or the direction set, so a second job on the same tile — another spp, another set, the
// studio's next preview after a direction or texel change — takes the one already built.
#pragma once
#include <btf/core/run_context.h>
#include <btf/geometry/mesh.h>
#include <btf/sim/network.h>
#include <btf/trace/periodic_tracer.h>

#include <memory>

namespace btf {

/// The network of `geom` (traced by `tracer`, built from it) with `settings`: a cached one when
/// one was built for the same geometry (checksum, triangle count, period) and settings, else a
/// new build, kept for later. At most two networks and 1 GiB are kept (least recently used go);
/// `*reused` says which. Thread-safe; two callers asking at once may both build.
std::shared_ptr<const PointNetwork> sharedNetwork(const PeriodicTracer& tracer,
                                                  const TileGeometry& geom,
                                                  const NetworkSettings& settings,
                                                  const CancelToken* cancel, bool* reused);

/// Drops every cached network (tests measuring a build; a process freeing memory).
void clearNetworkCache();

}  // namespace btf
