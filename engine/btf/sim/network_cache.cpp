// The process's cache of point networks (engine/btf/sim/network_cache.h).
#include <btf/sim/network_cache.h>

#include <cstring>
#include <list>
#include <mutex>

namespace btf {

namespace {

struct Key {
  uint64_t geometry = 0;
  size_t triangles = 0;
  double Lx = 0, Ly = 0;
  NetworkSettings s;
  bool operator==(const Key& o) const {
    return geometry == o.geometry && triangles == o.triangles && Lx == o.Lx && Ly == o.Ly &&
           s.voxels == o.s.voxels && s.minDistance == o.s.minDistance &&
           s.alphaDirections == o.s.alphaDirections && s.links == o.s.links &&
           s.gather == o.s.gather && s.gatherOcclusion == o.s.gatherOcclusion && s.seed == o.s.seed;
  }
};

struct Entry {
  Key key;
  std::shared_ptr<const PointNetwork> network;
};

constexpr size_t kMaxEntries = 2;
constexpr uint64_t kMaxBytes = uint64_t(1) << 30;

std::mutex g_mutex;
std::list<Entry> g_entries;  // most recently used first

}  // namespace

std::shared_ptr<const PointNetwork> sharedNetwork(const PeriodicTracer& tracer,
                                                  const TileGeometry& geom,
                                                  const NetworkSettings& settings,
                                                  const CancelToken* cancel, bool* reused) {
  const Key key{geom.checksum(), geom.triangleCount(), geom.Lx, geom.Ly, settings};
  {
    std::lock_guard lock(g_mutex);
    for (auto it = g_entries.begin(); it != g_entries.end(); ++it)
      if (it->key == key) {
        g_entries.splice(g_entries.begin(), g_entries, it);
        if (reused) *reused = true;
        return g_entries.front().network;
      }
  }
  auto n = std::make_shared<PointNetwork>();
  n->build(tracer, settings, nullptr, cancel);  // throws when cancelled: nothing kept
  if (reused) *reused = false;
  std::shared_ptr<const PointNetwork> shared = n;
  if (n->memoryBytes() > kMaxBytes) return shared;
  std::lock_guard lock(g_mutex);
  g_entries.push_front({key, shared});
  uint64_t bytes = 0;
  size_t kept = 0;
  for (auto it = g_entries.begin(); it != g_entries.end();) {
    bytes += it->network->memoryBytes();
    if (kept >= kMaxEntries || bytes > kMaxBytes) {
      it = g_entries.erase(it);
    } else {
      ++kept;
      ++it;
    }
  }
  return shared;
}

void clearNetworkCache() {
  std::lock_guard lock(g_mutex);
  g_entries.clear();
}

}  // namespace btf
