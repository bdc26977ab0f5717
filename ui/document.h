// The open scene with undo/redo (the editor's data model, no GL). Every edit goes through the
// scene's canonical JSON and the engine's parser, so the one parameter declaration validates it:
// an invalid edit throws btf::Error naming the JSON path and leaves the scene untouched.
#pragma once
#include <btf/scene/scene.h>

#include <filesystem>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

namespace btf::ui {

class Document {
 public:
  Document();
  /// Loads a scene file (throws btf::Error; the current scene stays on failure).
  void open(const std::filesystem::path& path);
  /// Replaces the scene by a parsed one (new document, empty history).
  void reset(Scene scene, std::filesystem::path path);
  /// Atomic save (temporary file + rename); marks the document clean.
  void save(const std::filesystem::path& path);

  const Scene& scene() const { return m_scene; }
  const std::string& json() const { return m_json; }  // canonical JSON of scene()
  const std::filesystem::path& path() const { return m_path; }
  bool dirty() const { return m_json != m_savedJson; }
  /// Incremented on every change of the scene (edits, undo, redo, open).
  uint64_t revision() const { return m_revision; }

  /// Sets the value at a JSON pointer of the canonical scene ("/parts/1/height",
  /// "/materials/brick/diffuse", "/simulation/spp") and re-parses. Throws btf::Error.
  void set(const std::string& pointer, const nlohmann::ordered_json& value,
           const std::string& label = "", bool merge = false);
  /// Applies any change of the canonical JSON (add/remove/duplicate/reorder parts...).
  void edit(const std::string& label, const std::function<void(nlohmann::ordered_json&)>& change);
  /// Value at a pointer of the canonical JSON (throws btf::Error when absent).
  nlohmann::ordered_json get(const std::string& pointer) const;

  bool canUndo() const { return !m_undo.empty(); }
  bool canRedo() const { return !m_redo.empty(); }
  void undo();
  void redo();
  /// Label of the edit that undo() would revert ("" when none).
  std::string undoLabel() const { return m_undo.empty() ? "" : m_undo.back().label; }
  std::string redoLabel() const { return m_redo.empty() ? "" : m_redo.back().label; }
  size_t undoDepth() const { return m_undo.size(); }

 private:
  struct Step {
    std::string label, json;
  };
  void commit(const std::string& label, Scene next, bool merge = false);
  void load(const std::string& json);
  Scene m_scene;
  std::string m_json, m_savedJson;
  std::filesystem::path m_path;
  std::vector<Step> m_undo, m_redo;
  uint64_t m_revision = 0;
  bool m_mergeable = false;  // the last step may absorb the next edit of the same label (drags)
};

/// The scene of a new document: a flat Lambert tile.
Scene defaultScene();

}  // namespace btf::ui
