#include "document.h"

#include <btf/core/error.h>

#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>

namespace btf::ui {

using Json = nlohmann::ordered_json;  // keeps the scene's key and material order

namespace {
constexpr size_t kMaxUndo = 1000;

const char* kDefaultScene = R"({
  "btfscene": 1, "name": "untitled", "tile": {"size": [1.0, 1.0]},
  "materials": {"white": {"type": "lambert", "albedo": [0.8, 0.8, 0.8]}},
  "parts": [{"name": "ground", "type": "plane", "material": "white", "height": 0.0}],
  "simulation": {"texels": [32, 32], "directions": "bonn81", "spp": 1, "shadows": "map"}
})";
}  // namespace

Scene defaultScene() {
  return parseScene(kDefaultScene, "untitled", std::filesystem::current_path());
}

Document::Document() {
  reset(defaultScene(), {});
}

void Document::reset(Scene scene, std::filesystem::path path) {
  m_scene = std::move(scene);
  m_json = sceneToJson(m_scene);
  m_savedJson = m_json;
  m_path = std::move(path);
  m_undo.clear();
  m_redo.clear();
  m_mergeable = false;
  ++m_revision;
}

void Document::open(const std::filesystem::path& path) {
  reset(loadScene(path), path);
}

void Document::save(const std::filesystem::path& path) {
  const std::filesystem::path tmp = path.string() + ".partial";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw Error(path.string() + ": cannot write (" + tmp.string() + ")");
    f << m_json << "\n";
    f.flush();
    if (!f) throw Error(path.string() + ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw Error(path.string() + ": cannot rename the saved file: " + ec.message());
  m_path = path;
  if (m_scene.baseDir.empty()) m_scene.baseDir = path.parent_path();
  m_savedJson = m_json;
}

Json Document::get(const std::string& pointer) const {
  const Json j = Json::parse(m_json);
  try {
    return j.at(Json::json_pointer(pointer));
  } catch (const Json::exception& e) {
    throw Error("scene has no value at '" + pointer + "'");
  }
}

void Document::set(const std::string& pointer, const Json& value, const std::string& label,
                   bool merge) {
  Json j = Json::parse(m_json);
  {
    Json::json_pointer p;
    try {
      p = Json::json_pointer(pointer);
    } catch (const Json::exception&) {
      throw Error("invalid parameter path '" + pointer + "' (expected /parts/0/height style)");
    }
    if (!j.contains(p)) throw Error("scene has no parameter at '" + pointer + "'");
    j[p] = value;
  }
  Scene next =
      parseScene(j.dump(), m_scene.source.empty() ? "scene" : m_scene.source, m_scene.baseDir);
  commit(label.empty() ? "set " + pointer : label, std::move(next), merge);
}

void Document::edit(const std::string& label, const std::function<void(Json&)>& change) {
  Json j = Json::parse(m_json);
  change(j);
  // The engine's parser is the validator: ranges, types, unknown keys, missing materials.
  Scene next =
      parseScene(j.dump(), m_scene.source.empty() ? "scene" : m_scene.source, m_scene.baseDir);
  commit(label, std::move(next));
}

void Document::commit(const std::string& label, Scene next, bool merge) {
  std::string nextJson = sceneToJson(next);
  if (nextJson == m_json) return;  // no-op edits do not fill the history
  if (!(merge && m_mergeable && !m_undo.empty() && m_undo.back().label == label)) {
    m_undo.push_back({label, m_json});
    if (m_undo.size() > kMaxUndo) m_undo.erase(m_undo.begin());
  }
  m_mergeable = true;  // the next drag step of the same label may merge into this one
  m_redo.clear();
  next.source = m_scene.source;
  next.baseDir = m_scene.baseDir;
  m_scene = std::move(next);
  m_json = std::move(nextJson);
  ++m_revision;
}

void Document::load(const std::string& text) {
  m_mergeable = false;
  Scene s = parseScene(text, m_scene.source, m_scene.baseDir);
  s.source = m_scene.source;
  s.baseDir = m_scene.baseDir;
  m_scene = std::move(s);
  m_json = text;
  ++m_revision;
}

void Document::undo() {
  if (m_undo.empty()) return;
  Step s = std::move(m_undo.back());
  m_undo.pop_back();
  m_redo.push_back({s.label, m_json});
  load(s.json);
}

void Document::redo() {
  if (m_redo.empty()) return;
  Step s = std::move(m_redo.back());
  m_redo.pop_back();
  m_undo.push_back({s.label, m_json});
  load(s.json);
}

}  // namespace btf::ui
