// Widgets for the engine's request declarations (btf/ops): the Jobs panel edits its requests
// through these, as the scene panel edits the scene through the scene's declarations.
#include <imgui.h>
#include <imgui_stdlib.h>

#include <cmath>

#include "panels.h"

namespace btf::ui {

bool requestParam(ops::Request& r, const ParamDecl& d, std::string* error) {
  ImGui::PushID(d.name.c_str());
  const std::string label = ops::optionName(r.decl(), d.name).substr(2);
  bool changed = false;
  auto commit = [&](const std::string& text) {
    try {
      r.set(d.name, text);
      changed = true;
      if (error) error->clear();
    } catch (const std::exception& e) {
      if (error) *error = e.what();
    }
  };
  const std::string current = r.has(d.name) ? r.text(d.name) : std::string();
  switch (d.type) {
    case ParamType::Int:
    case ParamType::Float: {
      double v = r.has(d.name) ? r.f(d.name) : (d.def.empty() ? 0.0 : d.def[0]);
      const double lo = std::isfinite(d.min) ? d.min : -1e9,
                   hi = std::isfinite(d.max) ? d.max : 1e9;
      const bool isInt = d.type == ParamType::Int;
      const float speed = float(std::min(1.0, (hi - lo) / 400));
      if (ImGui::DragScalar(label.c_str(), ImGuiDataType_Double, &v, isInt ? 0.2f : speed, &lo, &hi,
                            isInt ? "%.0f" : "%.4g")) {
        char buf[64];
        std::snprintf(buf, sizeof buf, isInt ? "%.0f" : "%.10g", isInt ? std::round(v) : v);
        commit(buf);
      }
      break;
    }
    case ParamType::Bool: {
      bool v = r.has(d.name) && r.b(d.name);
      if (ImGui::Checkbox(label.c_str(), &v)) commit(v ? "true" : "false");
      break;
    }
    case ParamType::Enum: {
      if (ImGui::BeginCombo(label.c_str(), current.c_str())) {
        for (const auto& c : d.choices)
          if (ImGui::Selectable(c.c_str(), c == current)) commit(c);
        ImGui::EndCombo();
      }
      break;
    }
    default: {
      std::string text = current;
      if (ImGui::InputText(label.c_str(), &text, ImGuiInputTextFlags_EnterReturnsTrue))
        commit(text);
    }
  }
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", d.doc.c_str());
  ImGui::PopID();
  return changed;
}

}  // namespace btf::ui
