// Image output through OpenImageIO. EXR keeps linear float values; PNG is tone mapped:
// display = clamp(value · scale), then the sRGB transfer curve, 8 bits (docs/cli.md).
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace btf {

/// Name → value attributes written into an image (EXR: string attributes "btf:NAME").
using ImageMetadata = std::vector<std::pair<std::string, std::string>>;

/// Writes an RGB float image (row 0 = first row in memory is written as the image's top row
/// when flipY is false), atomically. The format follows the extension: .exr (linear float, with
/// `metadata` as string attributes) or .png (8 bits, sRGB curve, an sRGB chunk); anything else
/// is refused with the path. `scale` multiplies values for PNG only. Non-finite values → 0.
void writeRgbImage(const std::string& path, int width, int height, const std::vector<float>& rgb,
                   float scale = 1.0f, bool flipY = true, const ImageMetadata& metadata = {});
/// Reads an image as RGB float (grey expanded); for tests and inspection.
std::vector<float> readRgbImage(const std::string& path, int* width, int* height);
/// sRGB transfer curve of a linear value in [0, 1].
float linearToSrgb(float v);

}  // namespace btf
