// Image output through OpenImageIO. EXR keeps linear float values; PNG is tone mapped:
// display = clamp(value · scale), then the sRGB transfer curve, 8 bits (docs/cli.md).
#pragma once
#include <string>
#include <vector>

namespace btf {

/// Writes an RGB float image (row 0 = first row in memory is written as the image's top row
/// when flipY is false). The format follows the extension (.exr, .png, .hdr, .tif...).
/// `scale` multiplies values for 8-bit formats only. Non-finite values are written as 0.
void writeRgbImage(const std::string& path, int width, int height, const std::vector<float>& rgb,
                   float scale = 1.0f, bool flipY = true);
/// Reads an image as RGB float (grey expanded); for tests and inspection.
std::vector<float> readRgbImage(const std::string& path, int* width, int* height);
/// sRGB transfer curve of a linear value in [0, 1].
float linearToSrgb(float v);

}  // namespace btf
