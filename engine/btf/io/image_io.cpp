#include <OpenImageIO/imageio.h>
#include <btf/core/error.h>
#include <btf/io/image_io.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace btf {

float linearToSrgb(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

void writeRgbImage(const std::string& path, int w, int h, const std::vector<float>& rgb,
                   float scale, bool flipY, const ImageMetadata& metadata) {
  writeRgbaImage(path, w, h, rgb, nullptr, scale, flipY, metadata);
}

void writeRgbaImage(const std::string& path, int w, int h, const std::vector<float>& rgb,
                    const std::vector<float>* alpha, float scale, bool flipY,
                    const ImageMetadata& metadata) {
  BTF_CHECK(rgb.size() == size_t(w) * h * 3);
  BTF_CHECK(!alpha || alpha->size() == size_t(w) * h);
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".exr" && ext != ".png")
    throw Error(path + ": unsupported image type '" + ext +
                "' (expected .exr, linear float, or .png, sRGB)");
  const bool hdr = ext == ".exr";
  const int nc = hdr && alpha ? 4 : 3;  // PNG: the colour over black, no alpha
  // Images are stored bottom row first in memory (v up); files are top row first.
  std::vector<float> px(size_t(w) * size_t(h) * size_t(nc));
  for (int j = 0; j < h; ++j) {
    const int src = flipY ? h - 1 - j : j;
    for (int i = 0; i < w; ++i) {
      const size_t sp = size_t(src) * size_t(w) + size_t(i), dp = size_t(j) * size_t(w) + size_t(i);
      for (int c = 0; c < 3; ++c) {
        float v = rgb[sp * 3 + size_t(c)];
        if (!std::isfinite(v)) v = 0;
        px[dp * size_t(nc) + size_t(c)] = hdr ? v : linearToSrgb(v * scale);
      }
      if (nc == 4) {
        const float a = (*alpha)[sp];
        px[dp * 4 + 3] = std::isfinite(a) ? std::clamp(a, 0.f, 1.f) : 0.f;
      }
    }
  }
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  const std::string tmp = path + ".tmp" + ext;  // keep the extension so OIIO picks the format
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw Error(path + ": cannot write images of this type (" + OIIO::geterror() + ")");
  OIIO::ImageSpec spec(w, h, nc, hdr ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::UINT8);
  if (hdr) {
    spec.format = OIIO::TypeDesc::FLOAT;
    spec.attribute("oiio:ColorSpace", "Linear");
    for (const auto& [k, v] : metadata) spec.attribute("btf:" + k, v);
  } else {
    spec.attribute("oiio:ColorSpace", "sRGB");  // the PNG writer adds the sRGB chunk
  }
  if (!out->open(tmp, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, px.data()) || !out->close())
    throw Error(path + ": cannot write image (" + out->geterror() + ")");
  std::filesystem::rename(tmp, path);
}

std::vector<float> readRgbImage(const std::string& path, int* w, int* h,
                                std::vector<float>* alpha) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(path + ": cannot read image (" + OIIO::geterror() + ")");
  const auto& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.width > 65536 ||
      spec.height > 65536 || spec.nchannels > 64 ||
      uint64_t(spec.width) * uint64_t(spec.height) * uint64_t(spec.nchannels) > (uint64_t(1) << 30))
    throw Error(path + ": refusing an image of " + std::to_string(spec.width) + "x" +
                std::to_string(spec.height) + "x" + std::to_string(spec.nchannels) +
                " channels (at most 65536 on a side, 2^30 values)");
  std::vector<float> all(size_t(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, all.data()))
    throw Error(path + ": cannot read image (" + in->geterror() + ")");
  *w = spec.width;
  *h = spec.height;
  std::vector<float> rgb(size_t(*w) * *h * 3);
  for (size_t p = 0; p < size_t(*w) * *h; ++p)
    for (int c = 0; c < 3; ++c)
      rgb[p * 3 + c] = all[p * spec.nchannels + std::min(c, spec.nchannels - 1)];
  if (alpha) {
    alpha->assign(size_t(*w) * *h, 1.0f);
    if (spec.alpha_channel >= 0 || spec.nchannels == 4) {
      const int a = spec.alpha_channel >= 0 ? spec.alpha_channel : 3;
      for (size_t p = 0; p < alpha->size(); ++p) (*alpha)[p] = all[p * spec.nchannels + size_t(a)];
    }
  }
  return rgb;
}

}  // namespace btf
