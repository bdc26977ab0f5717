// Live BRDF slices for the chosen light: the aBRDF over view directions as a hemisphere image
// with a colour bar (tile average, or the texel picked in the preview), in-plane and cross-plane
// θ curves of the tile average, and the picked texel's whole lights × views matrix.
#include <btf/directions/direction_set.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>

#include "panels.h"
#include "widgets.h"

namespace btf::ui {

namespace {

// The texel's aBRDF luminance over a G×G hemisphere for the light, interpolated on the set.
std::vector<float> texelHemisphere(const PreviewResult& r, double thetaL, double phiL, int G) {
  std::vector<float> img(size_t(G) * G, -1.f);
  const DirectionSet set = DirectionSet::fromName(r.matrixSet);
  const int n = set.size();
  const auto lw = set.interpolate(deg2rad(thetaL), deg2rad(phiL));
  for (int j = 0; j < G; ++j)
    for (int i = 0; i < G; ++i) {
      const double x = (i + 0.5) / G * 2 - 1, y = (j + 0.5) / G * 2 - 1;
      const double rr = std::sqrt(x * x + y * y);
      if (rr >= 0.999) continue;
      const auto vw = set.interpolate(std::asin(rr), std::atan2(y, x));
      double acc = 0;
      for (const auto& v : vw)
        for (const auto& l : lw)
          for (int c = 0; c < 3; ++c)
            acc += v.weight * l.weight *
                   r.matrix[(size_t(v.index) * size_t(n) + size_t(l.index)) * 3 + size_t(c)] / 3;
      img[size_t(j) * G + i] = float(acc);
    }
  return img;
}

}  // namespace

void drawBrdfPanel(const BrdfView& app) {
  PreviewState& pv = app.pv;
  if (!ImGui::Begin("BRDF", &app.open)) {
    ImGui::End();
    return;
  }
  const PreviewResult& r = pv.result;
  if (ImGui::RadioButton("tile average", pv.tileAverage))
    pv.tileAverage = true, pv.brdfStamp = ~0ull;
  ImGui::SameLine();
  if (ImGui::RadioButton("picked texel", !pv.tileAverage))
    pv.tileAverage = false, pv.brdfStamp = ~0ull;
  ImGui::SameLine();
  if (ImGui::Checkbox("log scale", &pv.logScale)) pv.brdfStamp = ~0ull;
  ImGui::SameLine();
  ImGui::TextDisabled("light (%.1f°, %.1f°)", pv.thetaL, pv.phiL);

  static float lo = 0, hi = 1;
  if (pv.brdfStamp != pv.stamp) {
    pv.brdfStamp = pv.stamp;
    std::vector<float> hemi;
    int G = 0;
    if (pv.tileAverage && r.brdfGrid > 0) {
      G = r.brdfGrid;
      hemi.assign(size_t(G) * G, -1.f);
      for (size_t k = 0; k < r.brdfValues.size(); ++k)
        hemi[size_t(r.brdfPixel[k])] = luminance(r.brdfValues[k]);
    } else if (!pv.tileAverage && !r.matrix.empty()) {
      G = 48;
      hemi = texelHemisphere(r, pv.thetaL, pv.phiL, G);
    }
    if (G > 0) {
      lo = 1e30f, hi = 0;
      for (float v : hemi)
        if (v >= 0) lo = std::min(lo, v), hi = std::max(hi, v);
      if (lo > hi) lo = hi = 0;
      if (!pv.logScale) lo = 0;
      const auto px = colourMapRgba8(hemi, G, G, lo, std::max(hi, lo + 1e-6f), pv.logScale, true);
      pv.hemisphere.setRgba8(G, G, px.data());
    }
    if (!r.matrix.empty()) {
      const int n = int(r.matrixDirsDeg.size());
      std::vector<float> m(size_t(n) * n);
      float mhi = 0;
      for (size_t k = 0; k < m.size(); ++k) {
        m[k] = (r.matrix[k * 3] + r.matrix[k * 3 + 1] + r.matrix[k * 3 + 2]) / 3;
        mhi = std::max(mhi, m[k]);
      }
      const auto px = colourMapRgba8(m, n, n, pv.logScale ? mhi * 1e-3f : 0, std::max(mhi, 1e-6f),
                                     pv.logScale, false);
      pv.matrix.setRgba8(n, n, px.data());
    }
  }
  const float side = std::clamp(ImGui::GetContentRegionAvail().x * 0.3f, 96.0f, 260.0f);
  ImGui::BeginGroup();
  ImGui::TextUnformatted(pv.tileAverage ? "over views (tile average)" : "over views (texel)");
  if (pv.hemisphere.id()) {
    ImGui::Image(pv.hemisphere.imguiId(), ImVec2(side, side));
    ImGui::SameLine();
    colourBar(lo, hi, pv.logScale, side);
  } else {
    ImGui::Dummy(ImVec2(side, side));
  }
  ImGui::EndGroup();
  ImGui::SameLine();
  ImGui::BeginGroup();
  ImGui::Text("lights × views, texel (%d, %d), %s", r.texelU, r.texelV, r.matrixSet.c_str());
  if (pv.matrix.id())
    ImGui::Image(pv.matrix.imguiId(), ImVec2(side, side));
  else
    ImGui::TextDisabled("computing…");
  if (ImGui::IsItemHovered() && !r.matrixDirsDeg.empty()) {
    const ImVec2 m = ImGui::GetIO().MousePos, p = ImGui::GetItemRectMin();
    const int n = int(r.matrixDirsDeg.size());
    const int l = std::clamp(int((m.x - p.x) / side * n), 0, n - 1);
    const int v = std::clamp(int((m.y - p.y) / side * n), 0, n - 1);
    const float* val = &r.matrix[(size_t(v) * n + l) * 3];
    ImGui::SetTooltip("view %d (%.0f°, %.0f°), light %d (%.0f°, %.0f°): %.4g %.4g %.4g", v,
                      r.matrixDirsDeg[v][0], r.matrixDirsDeg[v][1], l, r.matrixDirsDeg[l][0],
                      r.matrixDirsDeg[l][1], val[0], val[1], val[2]);
  }
  ImGui::EndGroup();
  if (!r.curveTheta.empty()) {
    std::vector<float> in, cross;
    for (size_t k = 0; k < r.curveTheta.size(); ++k) {
      in.push_back(luminance(r.inPlane[k]));
      cross.push_back(luminance(r.crossPlane[k]));
    }
    linePlot("##curves", r.curveTheta, {in, cross},
             {IM_COL32(255, 200, 60, 255), IM_COL32(80, 200, 255, 255)},
             {"in-plane (φ = φl, signed θo)", "cross-plane (φ = φl + 90°)"},
             ImVec2(ImGui::GetContentRegionAvail().x,
                    std::max(80.0f, ImGui::GetContentRegionAvail().y - 4)),
             pv.logScale);
  } else if (!r.error.empty()) {
    ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", r.error.c_str());
  }
  ImGui::End();
}

}  // namespace btf::ui
