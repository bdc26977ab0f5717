// Image output through OpenImageIO. EXR keeps linear float values; PNG is tone mapped:
// display = clamp(value · scale), then the sRGB transfer curve, 8 bits (docs/cli.md); JPEG too.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace btf {

/// Name → value attributes written into an image (EXR: string attributes "btf:NAME").
using ImageMetadata = std::vector<std::pair<std::string, std::string>>;

/// Writes an RGB float image (row 0 = first row in memory is written as the image's top row
/// when flipY is false), atomically. The format follows the extension: .exr (linear float, with
/// `metadata` as string attributes), .png (8 bits, sRGB curve, an sRGB chunk) or .jpg (8 bits,
/// sRGB, quality 95); anything else is refused with the path. `scale` multiplies values for
/// PNG/JPEG only. Non-finite values → 0.
void writeRgbImage(const std::string& path, int width, int height, const std::vector<float>& rgb,
                   float scale = 1.0f, bool flipY = true, const ImageMetadata& metadata = {});
/// Same with a coverage (alpha) channel: EXR only (RGBA); PNG ignores it.
void writeRgbaImage(const std::string& path, int width, int height, const std::vector<float>& rgb,
                    const std::vector<float>* alpha, float scale = 1.0f, bool flipY = true,
                    const ImageMetadata& metadata = {});
/// Reads an image as RGB float (grey expanded), top row first; `alpha`, when given, receives
/// the alpha channel (1 where the file has none). Through readImageChecked, at most 2^26 pixels.
std::vector<float> readRgbImage(const std::string& path, int* width, int* height,
                                std::vector<float>* alpha = nullptr);
/// Reads an image the careful way (docs/reliability.md): the extension must name a supported
/// format and the file start with its signature; an OpenEXR header is walked before OpenImageIO
/// allocates; the dimensions are checked against maxPixels (and 65536 a side) before a pixel is
/// decoded; libpng's own complaints are kept off stderr; every error is one line naming the file
/// and `what`. Decodes the first `decode` channels (0 = all; fewer when the file has fewer) into
/// `channels`, top row first.
std::vector<float> readImageChecked(const std::string& path, uint64_t maxPixels,
                                    const std::string& what, int* width, int* height, int* channels,
                                    int decode = 0);
/// sRGB transfer curve of a linear value in [0, 1].
float linearToSrgb(float v);

}  // namespace btf
