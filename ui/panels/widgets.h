// Small drawing helpers shared by the panels: tone mapping to RGBA8, a colour map with its bar,
// the hemisphere direction picker and line plots on ImGui draw lists (no ImPlot on Debian).
#pragma once
#include <btf/core/math.h>
#include <imgui.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace btf::ui {

/// Linear RGB → sRGB RGBA8 with `scale`; non-finite values become black.
std::vector<uint8_t> toneMapRgba8(const std::vector<float>& rgb, int w, int h, float scale,
                                  bool flipY);
/// Scalar field → colour-mapped RGBA8 over [lo, hi] (log10 when `logScale`; lo > 0 then).
std::vector<uint8_t> colourMapRgba8(const std::vector<float>& v, int w, int h, float lo, float hi,
                                    bool logScale, bool flipY);
/// The colour map (perceptually ordered, dark blue → yellow) at t in [0, 1].
ImU32 colourMap(float t);
/// A vertical colour bar with min / max labels, drawn at the cursor.
void colourBar(float lo, float hi, bool logScale, float height);
/// Orthographic hemisphere picker: (θ, φ) in degrees; returns true when the user changed it.
/// `marks` are other directions drawn as small dots (e.g. the set's directions).
bool hemispherePicker(const char* id, double* theta, double* phi, float size, ImU32 colour,
                      const std::vector<std::array<double, 2>>& marks = {});
/// Line plot of several series over shared x values; log scale on y when asked.
void linePlot(const char* id, const std::vector<double>& x,
              const std::vector<std::vector<float>>& series, const std::vector<ImU32>& colours,
              const std::vector<std::string>& names, ImVec2 size, bool logScale);
/// Luminance of an RGB value.
inline float luminance(const Rgb& c) {
  return (c.x + c.y + c.z) / 3.0f;
}

}  // namespace btf::ui
