// A request's option edited through the one ParamDecl widget (param_widget.cpp): the Jobs panel
// edits its requests through it, as the scene panel edits the scene.
#include <imgui.h>

#include "panels.h"

namespace btf::ui {

using json = nlohmann::ordered_json;

json requestValue(const ops::Request& r, const ParamDecl& d) {
  if (!r.has(d.name)) return d.type == ParamType::Bool ? json(false) : json();
  if (d.type == ParamType::Int || d.type == ParamType::Float) return r.f(d.name);
  if (d.type == ParamType::Bool) return r.b(d.name);
  return r.text(d.name);
}

bool requestParam(ops::Request& r, const ParamDecl& d, std::string* error) {
  ImGui::PushID(d.name.c_str());
  const ParamEdit e = paramWidget(ops::optionName(r.decl(), d.name).substr(2), d, requestValue(r, d));
  bool changed = false;
  if (e.changed) {
    try {
      r.set(d.name, paramText(d, e.value));
      changed = true;
      if (error) error->clear();
    } catch (const std::exception& ex) {
      if (error) *error = ex.what();
    }
  }
  ImGui::PopID();
  return changed;
}

}  // namespace btf::ui
