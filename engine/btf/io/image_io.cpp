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
  BTF_CHECK(rgb.size() == size_t(w) * h * 3);
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".exr" && ext != ".png")
    throw Error(path + ": unsupported image type '" + ext +
                "' (expected .exr, linear float, or .png, sRGB)");
  const bool hdr = ext == ".exr";
  // Images are stored bottom row first in memory (v up); files are top row first.
  std::vector<float> px(rgb.size());
  for (int j = 0; j < h; ++j) {
    const int src = flipY ? h - 1 - j : j;
    for (int i = 0; i < w * 3; ++i) {
      float v = rgb[size_t(src) * w * 3 + i];
      if (!std::isfinite(v)) v = 0;
      px[size_t(j) * w * 3 + i] = hdr ? v : linearToSrgb(v * scale);
    }
  }
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  const std::string tmp = path + ".tmp" + ext;  // keep the extension so OIIO picks the format
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw Error(path + ": cannot write images of this type (" + OIIO::geterror() + ")");
  OIIO::ImageSpec spec(w, h, 3, hdr ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::UINT8);
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

std::vector<float> readRgbImage(const std::string& path, int* w, int* h) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(path + ": cannot read image (" + OIIO::geterror() + ")");
  const auto& spec = in->spec();
  std::vector<float> all(size_t(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, all.data()))
    throw Error(path + ": cannot read image (" + in->geterror() + ")");
  *w = spec.width;
  *h = spec.height;
  std::vector<float> rgb(size_t(*w) * *h * 3);
  for (size_t p = 0; p < size_t(*w) * *h; ++p)
    for (int c = 0; c < 3; ++c)
      rgb[p * 3 + c] = all[p * spec.nchannels + std::min(c, spec.nchannels - 1)];
  return rgb;
}

}  // namespace btf
