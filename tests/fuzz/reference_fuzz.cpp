// Reference images of `btfsim render --reference` (an exact render's EXR with its coverage, or
// any RGB image): the first byte picks the extension (OpenEXR, PNG), the rest is the file, read
// as the renderer reads it and measured against an image of its size.
#include <btf/core/error.h>
#include <btf/io/image_io.h>
#include <btf/render/renderer.h>

#include <cmath>
#include <fstream>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "reference";

std::string writeReference(const uint8_t* data, size_t size) {
  if (size < 1) throw Error(inputDir() + "/input: empty fuzz input");
  static const char* const exts[] = {"exr", "png"};
  return writeInput(data + 1, size - 1, exts[data[0] % 2]);
}

std::string cliArgs(const uint8_t* data, size_t size) {
  const std::string ref = writeReference(data, size);
  const std::string scene = inputDir() + "/plane.json";
  std::ofstream(scene) << R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "plane", "material": "m"}]})";
  return "render " + scene + " --mode exact --object plane --size 8 --spp 1 -o " + inputDir() +
         "/out.exr --reference " + ref;
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string path = writeReference(data, size);
  RenderImage ref;
  ref.rgb = readRgbImage(path, &ref.width, &ref.height, &ref.alpha);
  check(ref.width > 0 && ref.height > 0 &&
            uint64_t(ref.width) * uint64_t(ref.height) <= (uint64_t(1) << 28),
        "size outside the bound");
  check(ref.rgb.size() == size_t(ref.width) * size_t(ref.height) * 3, "RGB count differs");
  check(ref.alpha.size() == size_t(ref.width) * size_t(ref.height), "alpha count differs");
  // What the renderer does with it: sanitise, then measure an image of the same size.
  for (float& v : ref.rgb)
    if (!std::isfinite(v)) v = 0;
  for (float& a : ref.alpha) a = std::isfinite(a) ? std::clamp(a, 0.f, 1.f) : 0.f;
  RenderImage img;
  img.width = ref.width, img.height = ref.height;
  img.rgb.assign(ref.rgb.size(), 0.5f);
  img.alpha.assign(ref.alpha.size(), 1.f);
  const ImageError e = compareImages(img, ref);
  check(std::isfinite(e.relRmse) && std::isfinite(e.coverageMismatch), "non-finite error");
}

}  // namespace btf::fuzz
