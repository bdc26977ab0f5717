// The adaptive sampler's statistics: samples per level, their histogram, the estimated error,
// and their JSON and vector forms (summed over chunks and ranks).
#include <btf/core/error.h>
#include <btf/sim/adaptive.h>

#include <cstdio>
#include <nlohmann/json.hpp>

namespace btf {

int adaptiveLevel(int K) {
  for (int L = 0; L < AdaptiveStats::kLevels; ++L)
    if ((2 << L) == K) return L;
  return -1;
}

double AdaptiveStats::meanSamples() const {
  double n = 0;
  for (const auto& v : values) n += double(v.load());
  return n > 0 ? double(samples.load()) / n : 0;
}

double AdaptiveStats::estimatedRelativeError() const {
  const double v = valueSq.load();
  return v > 0 ? std::sqrt(errorSq.load() / v) : 0;
}

std::string AdaptiveStats::histogramText() const {
  double n = 0;
  for (const auto& v : values) n += double(v.load());
  std::string s;
  for (int L = 0; L < kLevels; ++L) {
    const double c = double(values[size_t(L)].load());
    if (c == 0) continue;
    char b[64];
    std::snprintf(b, sizeof b, "%s%d×%d %.1f %%", s.empty() ? "" : ", ", 2 << L, 2 << L,
                  100.0 * c / std::max(1.0, n));
    s += b;
  }
  return s;
}

std::vector<double> AdaptiveStats::toVector() const {
  std::vector<double> v;
  for (const auto& x : values) v.push_back(double(x.load()));
  for (const auto* x : {&samples, &texelViews, &edgeTexelViews, &cameraRays})
    v.push_back(double(x->load()));
  v.push_back(errorSq.load());
  v.push_back(valueSq.load());
  return v;
}

void AdaptiveStats::assign(const std::vector<double>& v) {
  BTF_CHECK(v.size() == size_t(kLevels) + 6);
  size_t i = 0;
  for (auto& x : values) x = uint64_t(v[i++]);
  for (auto* x : {&samples, &texelViews, &edgeTexelViews, &cameraRays}) *x = uint64_t(v[i++]);
  errorSq = v[i++];
  valueSq = v[i++];
}

std::string AdaptiveStats::json() const {
  nlohmann::ordered_json j;
  nlohmann::ordered_json h = nlohmann::ordered_json::object();
  for (int L = 0; L < kLevels; ++L)
    if (values[size_t(L)].load())
      h[std::to_string(2 << L) + "x" + std::to_string(2 << L)] = values[size_t(L)].load();
  j["values_by_samples"] = h;
  j["mean_samples_per_value"] = meanSamples();
  j["texel_views"] = texelViews.load();
  j["edge_texel_views"] = edgeTexelViews.load();
  j["camera_rays"] = cameraRays.load();
  j["estimated_relative_error"] = estimatedRelativeError();
  return j.dump();
}

}  // namespace btf
