// The micro-structure editor: tile, materials and parts as a tree; every parameter edited
// through the engine's one declaration (ParamDecl: type, range, doc); add, remove, duplicate,
// reorder; errors from the engine shown next to the field while the scene stays as it was.
#include <btf/scene/params.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include <filesystem>

#include "panels.h"

namespace btf::ui {

using json = nlohmann::ordered_json;
namespace fs = std::filesystem;

namespace {

// One parameter through the shared widget; commits through App::setParam (drags merge into one
// undo step); the engine's refusal is shown below the field.
void editParam(const SceneView& app, const std::string& ptr, const ParamDecl& d,
               const json& value) {
  ImGui::PushID(ptr.c_str());
  std::vector<std::string> folders;
  if (d.type == ParamType::Path) {
    if (!app.doc.scene().baseDir.empty()) folders.push_back(app.doc.scene().baseDir);
    folders.push_back(BTF_RESOURCE_DIR "/meshes");
  }
  const ParamEdit e = paramWidget(d.name, d, value, folders);
  if (e.changed) {
    try {
      app.act.setParam(ptr, e.value, e.merge);
    } catch (const std::exception&) {
      // shown below the field
    }
  }
  auto it = app.fieldErrors.find(ptr);
  if (it != app.fieldErrors.end()) {
    ImGui::PushTextWrapPos(0);
    ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", it->second.c_str());
    ImGui::PopTextWrapPos();
  }
  ImGui::PopID();
}

void editDecl(const SceneView& app, const std::string& base, const TypeDecl& decl,
              const json& obj) {
  for (const ParamDecl& d : decl.params)
    if (obj.contains(d.name)) editParam(app, base + "/" + d.name, d, obj[d.name]);
}

void tryEdit(const SceneView& app, const std::string& label, const std::function<void(json&)>& f) {
  try {
    app.doc.edit(label, f);
  } catch (const std::exception& e) {
    app.act.message(e.what(), true);
  }
}

}  // namespace

void drawScenePanel(const SceneView& app) {
  if (!ImGui::Begin("Scene", &app.open)) {
    ImGui::End();
    return;
  }
  const json j = json::parse(app.doc.json());
  ImGui::Text("%s%s", app.doc.path().empty() ? "(unsaved scene)" : app.doc.path().c_str(),
              app.doc.dirty() ? " — modified" : "");
  if (ImGui::Button("Undo")) app.act.undo();
  ImGui::SameLine();
  if (ImGui::Button("Redo")) app.act.redo();
  ImGui::SameLine();
  ImGui::TextDisabled("%zu step(s)", app.doc.undoDepth());

  if (ImGui::CollapsingHeader("Tile", ImGuiTreeNodeFlags_DefaultOpen)) {
    std::string name = j["name"];
    if (ImGui::InputText("name", &name, ImGuiInputTextFlags_EnterReturnsTrue))
      tryEdit(app, "rename scene", [&](json& s) { s["name"] = name; });
    editDecl(app, "/tile", tileDecl(), j["tile"]);
  }
  if (ImGui::CollapsingHeader("Materials", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (auto it = j["materials"].begin(); it != j["materials"].end(); ++it) {
      const std::string name = it.key();
      ImGui::PushID(name.c_str());
      const bool open = ImGui::TreeNode(name.c_str(), "%s (%s)", name.c_str(),
                                        it.value()["type"].get<std::string>().c_str());
      ImGui::SameLine();
      if (ImGui::SmallButton("dup"))
        tryEdit(app, "duplicate material " + name, [&](json& s) {
          std::string n = name + "_copy";
          while (s["materials"].contains(n)) n += "_";
          s["materials"][n] = s["materials"][name];
        });
      ImGui::SameLine();
      if (ImGui::SmallButton("del"))
        tryEdit(app, "remove material " + name, [&](json& s) { s["materials"].erase(name); });
      if (open) {
        const std::string type = it.value()["type"];
        if (ImGui::BeginCombo("type", type.c_str())) {
          for (const auto& t : materialTypes())
            if (ImGui::Selectable(t.name.c_str(), t.name == type))
              tryEdit(app, "material type", [&](json& s) {
                s["materials"][name] = {{"type", t.name}};
              });
          ImGui::EndCombo();
        }
        if (const TypeDecl* d = findType(materialTypes(), type))
          editDecl(app, "/materials/" + name, *d, it.value());
        ImGui::TreePop();
      }
      ImGui::PopID();
    }
    if (ImGui::Button("+ material"))
      tryEdit(app, "add material", [&](json& s) {
        std::string n = "material";
        for (int k = 1; s["materials"].contains(n); ++k) n = "material" + std::to_string(k);
        s["materials"][n] = {{"type", "lambert"}};
      });
  }
  if (ImGui::CollapsingHeader("Parts", ImGuiTreeNodeFlags_DefaultOpen)) {
    const json& parts = j["parts"];
    for (size_t i = 0; i < parts.size(); ++i) {
      const json& p = parts[i];
      const std::string base = "/parts/" + std::to_string(i);
      ImGui::PushID(int(i));
      ImGuiTreeNodeFlags fl = int(i) == app.tile.selectedPart ? ImGuiTreeNodeFlags_Selected : 0;
      const bool open =
          ImGui::TreeNodeEx("part", fl, "%s (%s)", p["name"].get<std::string>().c_str(),
                            p["type"].get<std::string>().c_str());
      if (ImGui::IsItemClicked()) app.tile.selectedPart = int(i);
      ImGui::SameLine();
      if (ImGui::SmallButton("up") && i > 0)
        tryEdit(app, "move part up", [&](json& s) { std::swap(s["parts"][i], s["parts"][i - 1]); });
      ImGui::SameLine();
      if (ImGui::SmallButton("down") && i + 1 < parts.size())
        tryEdit(app, "move part down",
                [&](json& s) { std::swap(s["parts"][i], s["parts"][i + 1]); });
      ImGui::SameLine();
      if (ImGui::SmallButton("dup"))
        tryEdit(app, "duplicate part", [&](json& s) {
          json c = s["parts"][i];
          c["name"] = c["name"].get<std::string>() + "_copy";
          s["parts"].insert(s["parts"].begin() + long(i) + 1, c);
        });
      ImGui::SameLine();
      if (ImGui::SmallButton("del"))
        tryEdit(app, "remove part", [&](json& s) { s["parts"].erase(i); });
      if (open) {
        const std::string mat = p["material"];
        if (ImGui::BeginCombo("material", mat.c_str())) {
          for (auto m = j["materials"].begin(); m != j["materials"].end(); ++m)
            if (ImGui::Selectable(m.key().c_str(), m.key() == mat)) {
              try {
                app.act.setParam(base + "/material", m.key());
              } catch (const std::exception&) {
              }
            }
          ImGui::EndCombo();
        }
        if (const TypeDecl* d = findType(partTypes(), p["type"].get<std::string>()))
          editDecl(app, base, *d, p);
        if (ImGui::TreeNode("transform")) {
          editDecl(app, base + "/transform", transformDecl(), p["transform"]);
          ImGui::TreePop();
        }
        if (ImGui::TreeNode("array")) {
          editDecl(app, base + "/array", arrayDecl(), p["array"]);
          ImGui::TreePop();
        }
        ImGui::TreePop();
      }
      ImGui::PopID();
    }
    if (ImGui::BeginCombo("##add", "+ part")) {
      for (const auto& t : partTypes())
        if (ImGui::Selectable(t.name.c_str()))
          tryEdit(app, "add " + t.name, [&](json& s) {
            json part = {
                {"name", t.name}, {"type", t.name}, {"material", s["materials"].begin().key()}};
            for (const auto& d : t.params)
              if (d.required && d.type == ParamType::Path) part[d.name] = "";
            s["parts"].push_back(part);
          });
      ImGui::EndCombo();
    }
  }
  if (ImGui::CollapsingHeader("Simulation"))
    editDecl(app, "/simulation", simulationDecl(), j["simulation"]);
  ImGui::End();
}

}  // namespace btf::ui
