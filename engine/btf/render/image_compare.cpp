// Image comparison of two renders: RMS and relative error over all pixels and over the pixels
// both cover.
#include "render_internal.h"

namespace btf {

using namespace renderdetail;

ImageError compareImages(const RenderImage& img, const RenderImage& ref) {
  if (img.width != ref.width || img.height != ref.height)
    throw Error(format("images of different sizes (%dx%d vs %dx%d)", img.width, img.height,
                       ref.width, ref.height));
  ImageError e;
  double num = 0, den = 0, numIn = 0, denIn = 0;
  for (size_t p = 0; p < img.alpha.size(); ++p) {
    const bool a = img.alpha[p] >= 0.5f, b = ref.alpha[p] >= 0.5f;
    e.refPixels += b;
    e.mismatchPixels += a != b;
    e.extraPixels += a && !b;
    if (!a && !b) continue;
    const bool interior = img.alpha[p] >= 0.999f && ref.alpha[p] >= 0.999f;
    e.interiorPixels += interior;
    for (int k = 0; k < 3; ++k) {
      const double d = double(img.rgb[p * 3 + size_t(k)]) - double(ref.rgb[p * 3 + size_t(k)]);
      const double r2 = double(ref.rgb[p * 3 + size_t(k)]) * double(ref.rgb[p * 3 + size_t(k)]);
      num += d * d, den += r2;
      if (interior) numIn += d * d, denIn += r2;
    }
  }
  auto rel = [](double n, double d) { return d > 0 ? std::sqrt(n / d) : (n > 0 ? 1.0 : 0.0); };
  e.relRmse = rel(num, den);
  e.relRmseInterior = rel(numIn, denIn);
  e.coverageMismatch = e.refPixels > 0 ? double(e.mismatchPixels) / double(e.refPixels) : 0.0;
  return e;
}

}  // namespace btf
