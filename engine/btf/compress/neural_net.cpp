#include "neural_net.h"

#include <btf/core/rng.h>

#include <cmath>

namespace btf::nn {

int64_t Net::paramCount(const std::vector<int>& sizes) {
  int64_t n = 0;
  for (size_t l = 0; l + 1 < sizes.size(); ++l) n += int64_t(sizes[l + 1]) * (sizes[l] + 1);
  return n;
}

int64_t Net::wOffset(int layer) const {
  int64_t o = 0;
  for (int l = 0; l < layer; ++l) o += int64_t(sizes[size_t(l) + 1]) * (sizes[size_t(l)] + 1);
  return o;
}

void Net::init(uint64_t seed) {
  params.assign(size_t(paramCount(sizes)), 0.f);
  for (int l = 0; l < layers(); ++l) {
    const int64_t n = int64_t(sizes[size_t(l) + 1]) * sizes[size_t(l)];
    const double sigma = std::sqrt(2.0 / sizes[size_t(l)]);
    float* w = params.data() + wOffset(l);
    for (int64_t i = 0; i < n; ++i) {
      // Box-Muller from two counter-based uniforms.
      const uint64_t h = hashKeys(seed, uint64_t(l), uint64_t(i), 0x6e6e);
      const double u1 = (double(h >> 40) + 1) / 16777217.0, u2 = double(h & 0xffffff) / 16777216.0;
      w[i] = float(sigma * std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2));
    }
  }
}

void forward(const Net& n, const Mat& x, Pass& p, const Mat* firstLayer) {
  const int L = n.layers();
  p.a.resize(size_t(L) + 1);
  p.a[0] = x;
  for (int l = 0; l < L; ++l) {
    Mat& y = p.a[size_t(l) + 1];
    if (l == 0 && firstLayer)
      y = *firstLayer;
    else
      y.noalias() = n.W(l) * p.a[size_t(l)];
    if (!(l == 0 && firstLayer)) y.colwise() += n.b(l);
    if (l + 1 < L) y = y.cwiseMax(0.f);
  }
}

void backward(const Net& n, const Pass& p, const Mat& dOut, float* grad, Mat* dx) {
  const int L = n.layers();
  Mat d = dOut;  // ∂loss/∂(pre-activation of layer l)
  for (int l = L - 1; l >= 0; --l) {
    const Mat& in = p.a[size_t(l)];
    Eigen::Map<Mat> gW(grad + n.wOffset(l), n.sizes[size_t(l) + 1], n.sizes[size_t(l)]);
    Eigen::Map<Vec> gb(grad + n.bOffset(l), n.sizes[size_t(l) + 1]);
    gW.noalias() += d * in.transpose();
    gb += d.rowwise().sum();
    if (l == 0 && !dx) break;
    Mat back = n.W(l).transpose() * d;
    if (l == 0) {
      *dx = std::move(back);
      break;
    }
    // Through the ReLU of layer l − 1 (its output is `in`).
    d = back.cwiseProduct((in.array() > 0.f).cast<float>().matrix());
  }
}

void Adam::step(float* x, const float* g, size_t count, float lr, float beta1, float beta2,
                float eps) {
  if (m.size() != count) m.assign(count, 0.f), v.assign(count, 0.f), t = 0;
  ++t;
  const float c1 = 1.f / (1.f - std::pow(beta1, float(t)));
  const float c2 = 1.f / (1.f - std::pow(beta2, float(t)));
  for (size_t i = 0; i < count; ++i) {
    m[i] = beta1 * m[i] + (1 - beta1) * g[i];
    v[i] = beta2 * v[i] + (1 - beta2) * g[i] * g[i];
    x[i] -= lr * (m[i] * c1) / (std::sqrt(v[i] * c2) + eps);
  }
}

}  // namespace btf::nn
