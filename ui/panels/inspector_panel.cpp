// The compression inspector: ratio and error metrics per codec, per-texel and per-direction
// error maps with colour bars, original vs reconstructed spatial slices with their difference,
// and the worst texels and direction pairs (click one to show it).
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>

#include "panels.h"
#include "widgets.h"

namespace btf::ui {

namespace {

std::vector<float> sliceImage(const Decoder& d, int view, int light) {
  const BtfInfo& I = d.info();
  std::vector<float> img(size_t(I.texels()) * 3);
  for (int64_t t = 0; t < I.texels(); ++t) {
    const auto v = d.value(t, view, light);
    for (int c = 0; c < 3; ++c) img[size_t(t) * 3 + size_t(c)] = v[size_t(c)];
  }
  return img;
}

}  // namespace

void drawInspectorPanel(const InspectorView& app) {
  InspectorState& s = app.insp;
  if (!ImGui::Begin("Inspector", &app.open)) {
    ImGui::End();
    return;
  }
  static std::string path;
  ImGui::SetNextItemWidth(260);
  ImGui::InputText("compressed .cbtf", &path);
  ImGui::SameLine();
  if (ImGui::Button("Open")) {
    try {
      app.act.openCompressed(path, s.reference);
    } catch (const std::exception& e) {
      app.act.message(e.what(), true);
    }
  }
  if (!s.decoder) {
    ImGui::TextDisabled("Open a .cbtf (or run Simulate + compress in Jobs).");
    ImGui::End();
    return;
  }
  ImGui::TextWrapped("%s — %s", s.compressed.c_str(), s.header.c_str());
  ImGui::Text("reference: %s", s.reference.empty() ? "(none)" : s.reference.c_str());
  if (s.refDecoder) {
    ImGui::SameLine();
    if (ImGui::Button("Compare")) {
      try {
        app.act.compareInspector();
      } catch (const std::exception& e) {
        app.act.message(e.what(), true);
      }
    }
    ImGui::SameLine();
    if (ImGui::Button("Every codec")) {
      try {
        app.act.startCodecSweep(s.reference);
      } catch (const std::exception& e) {
        app.act.message(e.what(), true);
      }
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "compress the reference with every codec (nmf, svd, perview, lpca, tensor, neural) at the Jobs "
          "form's target ratio and compare each");
  }
  if (!s.codecs.empty() &&
      ImGui::BeginTable("codecs", 5, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit)) {
    for (const char* h : {"codec", "ratio", "RMSE", "rel. RMSE", "PSNR"})
      ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const auto& r : s.codecs) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(r.codec.c_str());
      ImGui::TableNextColumn();
      ImGui::Text("1:%.0f", r.ratio);
      ImGui::TableNextColumn();
      ImGui::Text("%.4g", r.rmse);
      ImGui::TableNextColumn();
      ImGui::Text("%.2f %%", 100 * r.relRmse);
      ImGui::TableNextColumn();
      ImGui::Text("%.2f dB", r.psnr);
    }
    ImGui::EndTable();
  }
  const BtfInfo& I = s.decoder->info();
  const int n = I.nDirs();
  bool changed = ImGui::SliderInt("view", &s.view, 0, n - 1);
  ImGui::SameLine();
  changed |= ImGui::SliderInt("light", &s.light, 0, n - 1);
  if (changed) s.texturesDirty = true;
  if (s.texturesDirty) {
    s.texturesDirty = false;
    const auto rec = sliceImage(*s.decoder, s.view, s.light);
    s.reconstructed.setRgba8(I.nu, I.nv, toneMapRgba8(rec, I.nu, I.nv, float(kPi), true).data());
    if (s.refDecoder) {
      const auto org = sliceImage(*s.refDecoder, s.view, s.light);
      s.original.setRgba8(I.nu, I.nv, toneMapRgba8(org, I.nu, I.nv, float(kPi), true).data());
      std::vector<float> diff(size_t(I.texels()));
      float hi = 1e-9f;
      for (size_t t = 0; t < diff.size(); ++t) {
        double d = 0;
        for (int c = 0; c < 3; ++c)
          d += std::abs(double(org[t * 3 + size_t(c)]) - rec[t * 3 + size_t(c)]);
        diff[t] = float(d / 3);
        hi = std::max(hi, diff[t]);
      }
      s.difference.setRgba8(I.nu, I.nv,
                            colourMapRgba8(diff, I.nu, I.nv, 0, hi, false, true).data());
    }
    if (s.haveReport) {
      const auto& r = s.report;
      const float th = *std::max_element(r.texelRmse.begin(), r.texelRmse.end());
      s.texelMap.setRgba8(
          r.nu, r.nv,
          colourMapRgba8(r.texelRmse, r.nu, r.nv, 0, std::max(th, 1e-9f), false, true).data());
      const float dh = *std::max_element(r.dirRmse.begin(), r.dirRmse.end());
      s.dirMap.setRgba8(
          r.nDirs, r.nDirs,
          colourMapRgba8(r.dirRmse, r.nDirs, r.nDirs, 0, std::max(dh, 1e-9f), false, false).data());
    }
  }
  const float side = std::clamp((ImGui::GetContentRegionAvail().x - 40) / 3, 64.0f, 256.0f);
  auto image = [&](const char* title, const gl::Texture& t) {
    ImGui::BeginGroup();
    ImGui::TextUnformatted(title);
    if (t.id())
      ImGui::Image(t.imguiId(), ImVec2(side, side));
    else
      ImGui::Dummy(ImVec2(side, side));
    ImGui::EndGroup();
  };
  image("original", s.original);
  ImGui::SameLine();
  image("reconstructed", s.reconstructed);
  ImGui::SameLine();
  image("|difference|", s.difference);
  if (s.haveReport) {
    const auto& r = s.report;
    ImGui::Text("RMSE %.4g, relative %.2f %%, PSNR %.2f dB, max |error| %.4g", r.rmse,
                100 * r.relRmse, r.psnr, r.maxAbs);
    image("per-texel RMSE", s.texelMap);
    ImGui::SameLine();
    colourBar(0, *std::max_element(r.texelRmse.begin(), r.texelRmse.end()), false, side);
    ImGui::SameLine();
    image("per-direction RMSE (views × lights)", s.dirMap);
    ImGui::SameLine();
    colourBar(0, *std::max_element(r.dirRmse.begin(), r.dirRmse.end()), false, side);
    ImGui::BeginGroup();
    ImGui::TextUnformatted("worst texels");
    for (const auto& w : r.worstTexels) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "(%d, %d) RMSE %.4g", int(w.index % r.nu), int(w.index / r.nu),
                    w.rmse);
      if (ImGui::Selectable(buf)) {
        app.pv.texelU = int(w.index % r.nu) * app.pv.size / r.nu;
        app.pv.texelV = int(w.index / r.nu) * app.pv.size / r.nv;
        app.pv.tileAverage = false;
        app.act.requestPreview();
      }
    }
    ImGui::EndGroup();
    ImGui::SameLine();
    ImGui::BeginGroup();
    ImGui::TextUnformatted("worst direction pairs");
    for (const auto& w : r.worstDirections) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "view %d, light %d: RMSE %.4g", int(w.index / r.nDirs),
                    int(w.index % r.nDirs), w.rmse);
      if (ImGui::Selectable(buf)) {
        s.view = int(w.index / r.nDirs);
        s.light = int(w.index % r.nDirs);
        s.texturesDirty = true;
      }
    }
    ImGui::EndGroup();
  }
  ImGui::End();
}

}  // namespace btf::ui
