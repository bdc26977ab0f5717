// The one widget that edits a value of a ParamDecl (btf/scene/params.h): the scene panel edits
// the scene's parameters through it, the Jobs panel the options of its requests. The value is
// JSON (a number, a flag, a string, an array for RGB and vectors), as the scene file and a
// request's echo hold it; the caller commits the new value its own way (an undo step, a
// Request::set) and shows the engine's answer.
#include <imgui.h>
#include <imgui_stdlib.h>

#include <cmath>
#include <filesystem>

#include "panels.h"

namespace btf::ui {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

ParamEdit paramWidget(const std::string& label, const ParamDecl& d, const json& value,
                      const std::vector<std::string>& pickFolders) {
  ParamEdit edit;
  const char* l = label.c_str();
  // The declared range bounds the drags; unbounded sides stop at ±1e9.
  const double lo = std::isfinite(d.min) ? d.min : -1e9, hi = std::isfinite(d.max) ? d.max : 1e9;
  const float speed =
      float(std::isfinite(d.max) && std::isfinite(d.min) ? std::min(1.0, (hi - lo) / 400) : 0.01);
  auto changed = [&](json v) {
    edit.changed = true;
    // A drag's later frames merge into the undo step its first frame made.
    edit.merge = !ImGui::IsItemActivated();
    edit.value = std::move(v);
  };
  auto num = [&](size_t i) {
    const json& v = value.is_array() ? value[i] : value;
    return v.is_number() ? v.get<double>() : (i < d.def.size() ? d.def[i] : 0.0);
  };
  switch (d.type) {
    case ParamType::Float: {
      double v = num(0);
      if (ImGui::DragScalar(l, ImGuiDataType_Double, &v, speed, &lo, &hi, "%.4g")) changed(v);
      break;
    }
    case ParamType::Int: {
      int v = int(std::lround(num(0)));
      if (ImGui::DragInt(l, &v, 0.2f, int(std::max(lo, -1e9)), int(std::min(hi, 1e9))))
        changed(v);
      break;
    }
    case ParamType::Bool: {
      bool v = value.is_boolean() && value.get<bool>();
      if (ImGui::Checkbox(l, &v)) changed(v);
      break;
    }
    case ParamType::Rgb: {
      float c[3] = {float(num(0)), float(num(1)), float(num(2))};
      if (ImGui::ColorEdit3(l, c, ImGuiColorEditFlags_Float)) changed({c[0], c[1], c[2]});
      break;
    }
    case ParamType::Vec2:
    case ParamType::Vec3: {
      const int n = d.type == ParamType::Vec2 ? 2 : 3;
      double v[3] = {0, 0, 0};
      for (int i = 0; i < n; ++i) v[i] = num(size_t(i));
      if (ImGui::DragScalarN(l, ImGuiDataType_Double, v, n, speed, &lo, &hi, "%.4g")) {
        json a = json::array();
        for (int i = 0; i < n; ++i) a.push_back(v[i]);
        changed(a);
      }
      break;
    }
    case ParamType::Int2: {
      int v[2] = {int(std::lround(num(0))), int(std::lround(num(1)))};
      if (ImGui::DragInt2(l, v, 0.2f)) changed({v[0], v[1]});
      break;
    }
    case ParamType::Enum: {
      const std::string cur = value.is_string() ? value.get<std::string>() : d.defStr;
      if (ImGui::BeginCombo(l, cur.c_str())) {
        for (const auto& c : d.choices)
          if (ImGui::Selectable(c.c_str(), c == cur)) changed(c);
        ImGui::EndCombo();
      }
      break;
    }
    case ParamType::String:
    case ParamType::Path: {
      std::string s = value.is_string() ? value.get<std::string>() : std::string();
      if (ImGui::InputText(l, &s, ImGuiInputTextFlags_EnterReturnsTrue)) changed(s);
      if (d.type == ParamType::Path && !pickFolders.empty()) {
        // A file picker over the given folders (the scene's own, the bundled meshes).
        ImGui::SameLine();
        if (ImGui::Button("...")) ImGui::OpenPopup("files");
        if (ImGui::BeginPopup("files")) {
          for (const auto& dir : pickFolders) {
            std::error_code ec;
            for (const auto& e : fs::directory_iterator(dir, ec)) {
              if (e.path().extension() == ".json") continue;
              if (ImGui::Selectable(e.path().string().c_str())) {
                changed(e.path().string());
                edit.merge = false;
              }
            }
          }
          ImGui::EndPopup();
        }
      }
      break;
    }
  }
  if (ImGui::IsItemHovered() && !d.doc.empty()) ImGui::SetTooltip("%s", d.doc.c_str());
  return edit;
}

std::string paramText(const ParamDecl& d, const json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number()) {
    char buf[64];
    if (d.type == ParamType::Int)
      std::snprintf(buf, sizeof buf, "%.0f", std::round(v.get<double>()));
    else
      std::snprintf(buf, sizeof buf, "%.10g", v.get<double>());
    return buf;
  }
  return v.dump();
}

}  // namespace btf::ui
