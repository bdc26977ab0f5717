// libbtf_oiio.so — the one unit that calls OpenImageIO, behind the C interface of
// btf/io/oiio_module.h; the engine loads it on its first image read or write. Every exception
// stops here and becomes the error text.
#include <OpenImageIO/imageio.h>
#include <btf/io/oiio_module.h>

#include <cstring>
#include <memory>
#include <string>

namespace {

void setError(char* err, size_t n, const std::string& what) {
  if (!err || n == 0) return;
  const size_t k = std::min(n - 1, what.size());
  std::memcpy(err, what.data(), k);
  err[k] = '\0';
}

}  // namespace

extern "C" {

__attribute__((visibility("default"))) int btf_oiio_abi(void) { return BTF_OIIO_ABI; }

__attribute__((visibility("default"))) int btf_oiio_write(const BtfOiioWrite* w, char* err,
                                                          size_t errSize) {
  try {
    auto out = OIIO::ImageOutput::create(w->path);
    if (!out) {
      setError(err, errSize, "cannot write images of this type (" + OIIO::geterror() + ")");
      return 1;
    }
    OIIO::ImageSpec spec(w->width, w->height, w->channels,
                         w->hdr ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::UINT8);
    if (w->hdr) {
      spec.format = OIIO::TypeDesc::FLOAT;
      spec.attribute("oiio:ColorSpace", "Linear");
      for (int k = 0; k < w->metaCount; ++k)
        spec.attribute(std::string("btf:") + w->metaKeys[k], w->metaValues[k]);
    } else {
      spec.attribute("oiio:ColorSpace", "sRGB");  // the PNG writer adds the sRGB chunk
      if (w->jpeg) {
        spec.attribute("compression", "jpeg:95");
        spec.attribute("jpeg:subsampling", "4:4:4");  // no chroma subsampling: texels are small
      }
    }
    if (!out->open(w->tmp, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, w->pixels) ||
        !out->close()) {
      setError(err, errSize, "cannot write image (" + out->geterror() + ")");
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    setError(err, errSize, std::string("cannot write image (") + e.what() + ")");
    return 1;
  }
}

__attribute__((visibility("default"))) void* btf_oiio_open(const char* plugin, const char* path,
                                                           BtfOiioSpec* spec, char* err,
                                                           size_t errSize) {
  try {
    auto in = OIIO::ImageInput::create(std::string(plugin));
    OIIO::ImageSpec opened;
    if (!in || !in->open(path, opened)) {
      setError(err, errSize, in ? in->geterror() : OIIO::geterror());
      return nullptr;
    }
    const OIIO::ImageSpec& s = in->spec();
    *spec = {s.width, s.height, s.nchannels, s.depth};
    return in.release();
  } catch (const std::exception& e) {
    setError(err, errSize, e.what());
    return nullptr;
  }
}

__attribute__((visibility("default"))) int btf_oiio_read(void* handle, int channels, float* out,
                                                         char* err, size_t errSize) {
  auto* in = static_cast<OIIO::ImageInput*>(handle);
  try {
    if (!in->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, out)) {
      setError(err, errSize, in->geterror());
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    setError(err, errSize, e.what());
    return 1;
  }
}

__attribute__((visibility("default"))) void btf_oiio_close(void* handle) {
  std::unique_ptr<OIIO::ImageInput> in(static_cast<OIIO::ImageInput*>(handle));
  if (in) in->close();
}
}
