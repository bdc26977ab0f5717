// The live single-direction preview: the tile's texel image for one view and light direction,
// rendered by the engine on the preview worker (quarter resolution, then full, then every effect
// of the plan), restarted on every edit; directions picked on hemispheres or typed.
#include <btf/directions/direction_set.h>
#include <imgui.h>

#include <chrono>

#include "panels.h"
#include "widgets.h"

namespace btf::ui {

using Clock = std::chrono::steady_clock;

void updatePreview(const PreviewView& app) {
  PreviewResult r;
  if (!app.preview.poll(&r)) return;
  PreviewState& pv = app.pv;
  if (pv.firstImageSeconds < 0 && !r.image.empty() && r.generation == pv.generation)
    pv.firstImageSeconds = std::chrono::duration<double>(Clock::now() - pv.requestTime).count();
  pv.result = std::move(r);
  ++pv.stamp;
}

namespace {
// A direction on a hemisphere picker plus typed degrees (θ clamped to [0, 89]; non-finite input
// is ignored). Returns true when it changed.
bool directionInput(const char* label, double* theta, double* phi, ImU32 colour) {
  ImGui::PushID(label);
  ImGui::TextUnformatted(label);
  bool changed = hemispherePicker("##pick", theta, phi, 90, colour);
  double v[2] = {*theta, *phi};
  ImGui::SetNextItemWidth(170);
  if (ImGui::InputScalarN("##typed", ImGuiDataType_Double, v, 2, nullptr, nullptr, "%.1f",
                          ImGuiInputTextFlags_EnterReturnsTrue) &&
      std::isfinite(v[0]) && std::isfinite(v[1])) {
    *theta = std::clamp(v[0], 0.0, 89.0);
    *phi = std::fmod(v[1], 360.0) + (v[1] < 0 ? 360.0 : 0.0);
    changed = true;
  }
  ImGui::PopID();
  return changed;
}
}  // namespace

void drawPreviewPanel(const PreviewView& app) {
  PreviewState& pv = app.pv;
  if (!ImGui::Begin("Preview", &app.open)) {
    ImGui::End();
    return;
  }
  const PreviewResult& r = pv.result;
  if (pv.imageStamp != pv.stamp && !r.image.empty()) {
    pv.imageStamp = pv.stamp;
    // π·exposure maps the aBRDF of a white Lambert surface to 1 (as btfsim slice's PNGs).
    const auto px = toneMapRgba8(r.image, r.nu, r.nv, float(kPi) * pv.exposure, true);
    pv.image.setRgba8(r.nu, r.nv, px.data());
  }
  // Left: the image; right: the direction pickers.
  const float side = std::max(64.0f, std::min(ImGui::GetContentRegionAvail().x - 190,
                                              ImGui::GetContentRegionAvail().y - 70));
  ImGui::BeginGroup();
  if (pv.image.id()) {
    const ImVec2 p0 = ImGui::GetCursorScreenPos();
    ImGui::Image(pv.image.imguiId(), ImVec2(side, side));
    // Where the image is, for the scripted session's pixel checks (framebuffer pixels).
    const float s = ImGui::GetIO().DisplayFramebufferScale.x;
    app.act.report()["preview_rect"] = {p0.x * s, p0.y * s, (p0.x + side) * s, (p0.y + side) * s};
    if (ImGui::IsItemClicked()) {
      const ImVec2 m = ImGui::GetIO().MousePos;
      pv.texelU = std::clamp(int((m.x - p0.x) / side * float(pv.size)), 0, pv.size - 1);
      pv.texelV = std::clamp(int((1 - (m.y - p0.y) / side) * float(pv.size)), 0, pv.size - 1);
      pv.tileAverage = false;
      app.act.requestPreview();
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("click: pick the texel of the BRDF views");
    // The picked texel.
    if (r.nu > 0) {
      const float u = (float(r.texelU) + 0.5f) / float(pv.size),
                  v = (float(r.texelV) + 0.5f) / float(pv.size);
      ImGui::GetWindowDrawList()->AddCircle(ImVec2(p0.x + u * side, p0.y + (1 - v) * side), 4,
                                            IM_COL32(255, 80, 80, 255));
    }
  } else {
    ImGui::Dummy(ImVec2(side, side));
  }
  ImGui::EndGroup();
  ImGui::SameLine();
  ImGui::BeginGroup();
  if (directionInput("view (θ, φ)", &pv.thetaV, &pv.phiV, IM_COL32(80, 200, 255, 255)))
    app.act.requestPreview();
  if (directionInput("light (θ, φ)", &pv.thetaL, &pv.phiL, IM_COL32(255, 210, 60, 255)))
    app.act.requestPreview();
  ImGui::SetNextItemWidth(100);
  if (ImGui::SliderFloat("exposure", &pv.exposure, 0.05f, 20, "%.2f", ImGuiSliderFlags_Logarithmic))
    pv.imageStamp = ~0ull;
  int idx = pv.size >= 128 ? 3 : pv.size >= 64 ? 2 : pv.size >= 32 ? 1 : 0;
  ImGui::SetNextItemWidth(100);
  if (ImGui::Combo("texels", &idx,
                   "16\0"
                   "32\0"
                   "64\0"
                   "128\0",
                   4)) {
    pv.size = 16 << idx;
    pv.texelU = pv.texelV = -1;
    app.act.requestPreview();
  }
  ImGui::EndGroup();
  if (!r.error.empty()) {
    ImGui::PushTextWrapPos(0);
    ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", r.error.c_str());
    ImGui::PopTextWrapPos();
  } else {
    ImGui::Text("%s%s — %d² texels, %.0f ms (first image %.0f ms)", r.stage.c_str(),
                app.preview.working() ? " …" : "", r.nu, r.imageSeconds * 1e3,
                pv.firstImageSeconds * 1e3);
  }
  if (!r.plan.empty() && ImGui::TreeNode("effect plan")) {
    ImGui::TextUnformatted(r.plan.c_str());
    ImGui::TreePop();
  }
  ImGui::End();
}

}  // namespace btf::ui
