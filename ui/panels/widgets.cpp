#include "widgets.h"

#include <btf/io/image_io.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace btf::ui {

std::vector<uint8_t> toneMapRgba8(const std::vector<float>& rgb, int w, int h, float scale,
                                  bool flipY) {
  std::vector<uint8_t> out(size_t(w) * h * 4, 255);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t src = (size_t(flipY ? h - 1 - y : y) * w + x) * 3;
      const size_t dst = (size_t(y) * w + x) * 4;
      for (int c = 0; c < 3; ++c) {
        float v = rgb[src + size_t(c)] * scale;
        if (!std::isfinite(v)) v = 0;
        out[dst + size_t(c)] =
            uint8_t(std::lround(255.0f * linearToSrgb(std::clamp(v, 0.0f, 1.0f))));
      }
    }
  return out;
}

ImU32 colourMap(float t) {
  // Control points of a viridis-like ramp.
  static const float k[6][3] = {{0.27f, 0.00f, 0.33f}, {0.25f, 0.28f, 0.53f},
                                {0.16f, 0.47f, 0.56f}, {0.13f, 0.66f, 0.51f},
                                {0.48f, 0.82f, 0.32f}, {0.99f, 0.91f, 0.14f}};
  if (!std::isfinite(t)) t = 0;
  t = std::clamp(t, 0.0f, 1.0f) * 5;
  const int i = std::min(4, int(t));
  const float f = t - i;
  float c[3];
  for (int j = 0; j < 3; ++j) c[j] = k[i][j] * (1 - f) + k[i + 1][j] * f;
  return IM_COL32(int(c[0] * 255), int(c[1] * 255), int(c[2] * 255), 255);
}

namespace {
float normalise(float v, float lo, float hi, bool logScale) {
  if (logScale) {
    lo = std::max(lo, 1e-6f);
    hi = std::max(hi, lo * 1.0001f);
    v = std::max(v, lo);
    return (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo));
  }
  return hi > lo ? (v - lo) / (hi - lo) : 0.0f;
}
}  // namespace

std::vector<uint8_t> colourMapRgba8(const std::vector<float>& v, int w, int h, float lo, float hi,
                                    bool logScale, bool flipY) {
  std::vector<uint8_t> out(size_t(w) * h * 4, 255);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float val = v[size_t(flipY ? h - 1 - y : y) * w + x];
      const ImU32 c =
          val < 0 ? IM_COL32(0, 0, 0, 255) : colourMap(normalise(val, lo, hi, logScale));
      const size_t d = (size_t(y) * w + x) * 4;
      out[d] = uint8_t(c & 255);
      out[d + 1] = uint8_t((c >> 8) & 255);
      out[d + 2] = uint8_t((c >> 16) & 255);
    }
  return out;
}

void colourBar(float lo, float hi, bool logScale, float height) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const float w = 14;
  const int steps = 32;
  for (int i = 0; i < steps; ++i) {
    const float y0 = p.y + height * (1 - float(i + 1) / steps);
    const float y1 = p.y + height * (1 - float(i) / steps);
    dl->AddRectFilled(ImVec2(p.x, y0), ImVec2(p.x + w, y1), colourMap((i + 0.5f) / steps));
  }
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", double(hi));
  dl->AddText(ImVec2(p.x + w + 4, p.y), IM_COL32(220, 220, 220, 255), buf);
  std::snprintf(buf, sizeof buf, "%.3g%s", double(logScale ? std::max(lo, 1e-6f) : lo),
                logScale ? " (log)" : "");
  dl->AddText(ImVec2(p.x + w + 4, p.y + height - ImGui::GetFontSize()),
              IM_COL32(220, 220, 220, 255), buf);
  ImGui::Dummy(ImVec2(w + 70, height));
}

bool hemispherePicker(const char* id, double* theta, double* phi, float size, ImU32 colour,
                      const std::vector<std::array<double, 2>>& marks) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const float r = size * 0.5f - 2;
  const ImVec2 c(p.x + size * 0.5f, p.y + size * 0.5f);
  ImGui::InvisibleButton(id, ImVec2(size, size));
  bool changed = false;
  if (ImGui::IsItemActive() && ImGui::IsMouseDown(0)) {
    const ImVec2 m = ImGui::GetIO().MousePos;
    double x = (m.x - c.x) / r, y = -(m.y - c.y) / r;
    const double rr = std::min(0.999, std::sqrt(x * x + y * y));
    const double th = std::asin(rr) * 180 / kPi;
    double ph = std::atan2(y, x) * 180 / kPi;
    if (ph < 0) ph += 360;
    if (std::abs(th - *theta) > 1e-9 || std::abs(ph - *phi) > 1e-9) {
      *theta = std::round(th * 10) / 10;
      *phi = std::round(ph * 10) / 10;
      changed = true;
    }
  }
  dl->AddCircleFilled(c, r, IM_COL32(40, 40, 48, 255), 48);
  for (double t : {30.0, 60.0})
    dl->AddCircle(c, r * float(std::sin(t * kPi / 180)), IM_COL32(90, 90, 100, 255), 48);
  dl->AddCircle(c, r, IM_COL32(140, 140, 150, 255), 48);
  dl->AddLine(ImVec2(c.x - r, c.y), ImVec2(c.x + r, c.y), IM_COL32(90, 90, 100, 255));
  dl->AddLine(ImVec2(c.x, c.y - r), ImVec2(c.x, c.y + r), IM_COL32(90, 90, 100, 255));
  for (const auto& m : marks) {
    const float s = float(std::sin(m[0] * kPi / 180));
    dl->AddCircleFilled(ImVec2(c.x + r * s * float(std::cos(m[1] * kPi / 180)),
                               c.y - r * s * float(std::sin(m[1] * kPi / 180))),
                        1.5f, IM_COL32(150, 150, 160, 200));
  }
  const float s = float(std::sin(*theta * kPi / 180));
  const ImVec2 q(c.x + r * s * float(std::cos(*phi * kPi / 180)),
                 c.y - r * s * float(std::sin(*phi * kPi / 180)));
  dl->AddCircleFilled(q, 5, colour);
  return changed;
}

void linePlot(const char* id, const std::vector<double>& x,
              const std::vector<std::vector<float>>& series, const std::vector<ImU32>& colours,
              const std::vector<std::string>& names, ImVec2 size, bool logScale) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p = ImGui::GetCursorScreenPos();
  ImGui::InvisibleButton(id, size);
  dl->AddRectFilled(p, ImVec2(p.x + size.x, p.y + size.y), IM_COL32(30, 30, 36, 255));
  if (x.empty()) return;
  float lo = 1e30f, hi = -1e30f;
  for (const auto& s : series)
    for (float v : s)
      if (std::isfinite(v) && (!logScale || v > 0)) lo = std::min(lo, v), hi = std::max(hi, v);
  if (lo > hi) lo = 0, hi = 1;
  if (!logScale) lo = std::min(lo, 0.0f);
  if (hi <= lo) hi = lo + 1;
  const double x0 = x.front(), x1 = x.back();
  const float padL = 48, padB = 16;
  auto X = [&](double v) { return p.x + padL + float((v - x0) / (x1 - x0)) * (size.x - padL - 4); };
  auto Y = [&](float v) {
    float t = 0;
    if (logScale)
      t = (std::log10(std::max(v, lo)) - std::log10(lo)) /
          std::max(1e-6f, std::log10(hi) - std::log10(lo));
    else
      t = (v - lo) / (hi - lo);
    return p.y + 4 + (1 - t) * (size.y - padB - 8);
  };
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", double(hi));
  dl->AddText(ImVec2(p.x + 2, p.y + 2), IM_COL32(200, 200, 200, 255), buf);
  std::snprintf(buf, sizeof buf, "%.3g", double(lo));
  dl->AddText(ImVec2(p.x + 2, p.y + size.y - padB - 14), IM_COL32(200, 200, 200, 255), buf);
  std::snprintf(buf, sizeof buf, "%.0f", x0);
  dl->AddText(ImVec2(X(x0), p.y + size.y - padB), IM_COL32(200, 200, 200, 255), buf);
  std::snprintf(buf, sizeof buf, "%.0f", x1);
  dl->AddText(ImVec2(X(x1) - 20, p.y + size.y - padB), IM_COL32(200, 200, 200, 255), buf);
  for (size_t s = 0; s < series.size(); ++s) {
    for (size_t i = 1; i < x.size() && i < series[s].size(); ++i)
      dl->AddLine(ImVec2(X(x[i - 1]), Y(series[s][i - 1])), ImVec2(X(x[i]), Y(series[s][i])),
                  colours[s % colours.size()], 1.5f);
    if (s < names.size())
      dl->AddText(ImVec2(p.x + padL + 8, p.y + 4 + 14 * float(s)), colours[s % colours.size()],
                  names[s].c_str());
  }
}

}  // namespace btf::ui
