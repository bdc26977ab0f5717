// The neural codec's network (docs/compression.md, "neural"): a small fully connected ReLU
// network in float32 over batches held as Eigen matrices (one column per sample) — forward,
// backward and Adam — written here so that reading or training a file needs no training library
// (docs/decisions/0006-neural-codec.md). Single-threaded per call: callers split batches into
// fixed shards, which keeps results independent of the thread count.
#pragma once
#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace btf::nn {

using Mat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic>;  // column-major
using Vec = Eigen::VectorXf;

/// Layer widths from input to output (sizes[0] inputs, sizes.back() outputs), ReLU after every
/// layer but the last. Parameters flat, per layer: W (out × in, column-major), then b (out).
struct Net {
  std::vector<int> sizes;
  std::vector<float> params;

  int layers() const { return int(sizes.size()) - 1; }
  static int64_t paramCount(const std::vector<int>& sizes);
  int64_t wOffset(int layer) const;
  int64_t bOffset(int layer) const { return wOffset(layer) + int64_t(sizes[size_t(layer) + 1]) *
                                                                 sizes[size_t(layer)]; }
  Eigen::Map<const Mat> W(int l) const {
    return {params.data() + wOffset(l), sizes[size_t(l) + 1], sizes[size_t(l)]};
  }
  Eigen::Map<const Vec> b(int l) const { return {params.data() + bOffset(l), sizes[size_t(l) + 1]}; }
  /// He-normal weights from the seed (counter-based), zero biases.
  void init(uint64_t seed);
};

/// One batch's activations, kept for backward: a[0] the input, a[l] the output of layer l
/// (after its ReLU; the last is linear).
struct Pass {
  std::vector<Mat> a;
};

/// Runs the network on x (sizes[0] × B). `firstLayer`, when given, replaces layer 0's W x + b
/// (sizes[1] × B, pre-activation): a caller that splits the input (latent and directions) adds
/// the two parts itself.
void forward(const Net& n, const Mat& x, Pass& p, const Mat* firstLayer = nullptr);
/// Back-propagates dOut = ∂loss/∂output (sizes.back() × B): adds ∂loss/∂params to grad and,
/// when dx is given, writes ∂loss/∂input (sizes[0] × B).
void backward(const Net& n, const Pass& p, const Mat& dOut, float* grad, Mat* dx);

/// Adam (Kingma & Ba) over a flat array.
struct Adam {
  std::vector<float> m, v;
  int64_t t = 0;
  void step(float* x, const float* g, size_t count, float lr, float beta1 = 0.9f,
            float beta2 = 0.999f, float eps = 1e-8f);
};

}  // namespace btf::nn
