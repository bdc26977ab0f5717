// Height images (a scene's `image` part): the first byte picks the extension (PNG, OpenEXR,
// PNM, Radiance HDR), the rest is the file, read with a bound of 2^20 pixels.
#include <btf/core/error.h>
#include <btf/geometry/builders.h>

#include <cmath>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "image";

std::string writeImage(const uint8_t* data, size_t size) {
  if (size < 1) throw Error(inputDir() + "/input: empty fuzz input");
  static const char* const exts[] = {"png", "exr", "pgm", "hdr"};
  return writeInput(data + 1, size - 1, exts[data[0] % 4]);
}

std::string cliArgs(const uint8_t* data, size_t size) {
  return "plan " + sceneWithFile("image", "path", writeImage(data, size));
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string path = writeImage(data, size);
  int w = 0, h = 0;
  const std::vector<float> px = readHeightImage(path, 1u << 20, &w, &h);
  check(w > 0 && h > 0 && uint64_t(w) * uint64_t(h) <= (1u << 20), "size outside the bound");
  check(px.size() == size_t(w) * size_t(h), "pixel count does not match the size");
  for (float v : px) check(std::isfinite(v), "non-finite height");
}

}  // namespace btf::fuzz
