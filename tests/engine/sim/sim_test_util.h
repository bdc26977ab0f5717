// Helpers shared by the simulator's tests: resource scenes, their options at a test size, a
// whole run into memory, and the per-value relative RMSE between two runs.
#pragma once
#include <btf/scene/scene.h>
#include <btf/sim/simulator.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "test_util.h"

namespace btf::test {

inline Scene resourceScene(const std::string& name) {
  return loadScene(sourceDir() + "/resources/scenes/" + name + ".json");
}

/// The scene's own options at `texels`² and direction set `dirs`, quiet.
inline SimOptions sceneOptions(const Scene& s, int texels, const std::string& dirs) {
  SimOptions o = optionsFromScene(s);
  o.nu = o.nv = texels;
  o.directions = dirs;
  o.progress = false;
  return o;
}

/// Every value of a run, texel-major (texel, view, light, channel).
inline std::vector<float> runAll(const Scene& s, SimOptions o, SimReport* rep = nullptr) {
  o.progress = false;
  SimulationJob job(s, o);
  const int n = job.directions().size();
  const size_t stride = size_t(n) * n * 3;
  std::vector<float> all(size_t(o.nu) * o.nv * stride);
  job.setChunkSink([&](int, int64_t t0, int64_t t1, const float* v) {
    std::copy(v, v + size_t(t1 - t0) * stride, all.begin() + ptrdiff_t(size_t(t0) * stride));
  });
  const SimReport r = job.run("", job.estimate(""));
  if (rep) *rep = r;
  return all;
}

inline double relativeRmse(const std::vector<float>& ref, const std::vector<float>& got) {
  double e = 0, r = 0;
  for (size_t k = 0; k < ref.size(); ++k) {
    e += double(got[k] - ref[k]) * (got[k] - ref[k]);
    r += double(ref[k]) * ref[k];
  }
  return std::sqrt(e / std::max(r, 1e-30));
}

}  // namespace btf::test
