// Does a dynamic-range transform before the codec pay? (issue 13, docs/compression.md)
// Codes y = log(1 + x/s) instead of x — s = the BTF's mean value times a factor — decodes
// x = s·(exp(y) − 1), and prints the linear relative RMSE of both against the input, at the
// same ratio. A development measurement, not a product path:
//   ninja -C build transform_study
//   build/app/transform_study REF.btf tensor 300 [factor ...]
#include <btf/compress/compress.h>
#include <btf/store/btf_store.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace btf;

namespace {

double relRmse(const std::vector<float>& ref, const std::vector<float>& x) {
  double e = 0, r = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    e += (double(x[i]) - ref[i]) * (double(x[i]) - ref[i]);
    r += double(ref[i]) * ref[i];
  }
  return std::sqrt(e / r);
}

// Codes `values` at the settings, returns the decoded values and the ratio.
std::vector<float> roundTrip(const BtfInfo& info, const std::vector<float>& values,
                             const CodecSettings& s, double* ratio) {
  const std::string path = "/tmp/transform_study.btf";
  {
    BtfWriter w(path, info, false);
    w.writeVmf({});
    const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
    for (int c = 0; c < info.chunks(); ++c)
      w.writeChunk(c, values.data() + size_t(info.chunkBegin(c)) * stride);
    w.finish();
  }
  const CompressedBtf c = compressStore(path, s, false, nullptr, nullptr);
  *ratio = c.ratio();
  const auto dec = makeDecoder(c);
  const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
  std::vector<float> out(values.size());
  for (int64_t t = 0; t < info.texels(); ++t) dec->texel(t, out.data() + size_t(t) * stride);
  std::remove(path.c_str());
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s REF.btf CODEC RATIO [factor ...]\n", argv[0]);
    return 2;
  }
  const auto ref = openBtf(argv[1]);
  BtfInfo info = ref->info();
  info.hasVmf = false;
  const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
  std::vector<float> x(size_t(info.texels()) * stride);
  for (int64_t t = 0; t < info.texels(); ++t) ref->texel(t, x.data() + size_t(t) * stride);
  double mean = 0;
  for (float v : x) mean += v;
  mean /= double(x.size());
  CodecSettings s;
  s.codec = argv[2];
  s.targetRatio = std::atof(argv[3]);
  double ratio = 0;
  const std::vector<float> plain = roundTrip(info, x, s, &ratio);
  std::printf("%s 1:%.0f  linear: ratio 1:%.1f  rel. RMSE %.2f %%\n", argv[2], s.targetRatio, ratio,
              100 * relRmse(x, plain));
  std::vector<double> factors;
  for (int i = 4; i < argc; ++i) factors.push_back(std::atof(argv[i]));
  if (factors.empty()) factors = {0.1, 1, 10};
  for (double f : factors) {
    const double sc = f * mean;
    std::vector<float> y(x.size());
    for (size_t i = 0; i < x.size(); ++i) y[i] = float(std::log1p(std::max(0.f, x[i]) / sc));
    std::vector<float> back = roundTrip(info, y, s, &ratio);
    for (float& v : back) v = float(sc * std::expm1(double(v)));
    std::printf("%s 1:%.0f  log(1 + x/(%.2g·mean)): ratio 1:%.1f  rel. RMSE %.2f %%\n", argv[2],
                s.targetRatio, f, ratio, 100 * relRmse(x, back));
  }
  return 0;
}
