// The panels, one per file (Tracy's View split): each is drawn from a view of exactly what it
// uses — its open flag, its own state, the shared state it reads, and the studio's actions —
// built by App::frame().
#pragma once
#include <btf/ops/request.h>

#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "../document.h"
#include "../job_requests.h"
#include "../jobs.h"
#include "../panel_state.h"
#include "../preview.h"
#include "../studio_actions.h"

namespace btf::ui {

struct SceneView {
  bool& open;
  Document& doc;
  std::map<std::string, std::string>& fieldErrors;  // JSON pointer → engine error
  TileViewState& tile;
  StudioActions& act;
};
struct TileViewView {
  bool& open;
  const Document& doc;
  PreviewState& pv;
  TileViewState& tile;
  int width, height;
  StudioActions& act;
};
struct PreviewView {
  bool& open;
  PreviewWorker& preview;
  PreviewState& pv;
  StudioActions& act;
};
struct BrdfView {
  bool& open;
  PreviewState& pv;
};
struct JobsView {
  bool& open;
  const Document& doc;
  JobForm& form;
  JobQueue& jobs;
  StudioActions& act;
};
struct InspectorView {
  bool& open;
  InspectorState& insp;
  PreviewState& pv;
  StudioActions& act;
};
struct ObjectView {
  bool& open;
  ObjectState& obj;
  InspectorState& insp;
  int width, height;
  StudioActions& act;
};
struct StudyView {
  bool& open;
  StudyState& study;
  StudioActions& act;
};

void updatePreview(const PreviewView& app);  // polls the worker, uploads textures (every frame)
void drawScenePanel(const SceneView& app);
void drawTileView(const TileViewView& app);
void drawPreviewPanel(const PreviewView& app);
void drawBrdfPanel(const BrdfView& app);
void drawJobsPanel(const JobsView& app);
void drawInspectorPanel(const InspectorView& app);
void drawObjectViewer(const ObjectView& app);
void drawStudyPanel(const StudyView& app);
/// Renders the GLSL decoder into a float target at `samples` random (x, y, ωi, ωo) and compares
/// with the CPU decoder (the script's check_glsl action).
bool checkGlsl(const ObjectView& app, int samples, double tolerance, nlohmann::json* result);
/// The renderer's settings for the viewer's view at w × h pixels: the orbit camera (perspective
/// 35°, its distance as a zoom), the light (turning with the camera), tiling, relief scale; one
/// sample per pixel at its centre, no texel levels. `radius`: the object's bounding radius.
RenderSettings viewerRenderSettings(const ObjectState& o, double radius, int w, int h);
/// Renders the GLSL mapped view (the shell march) at w × h into a float target and the CPU
/// renderer's mapped mode on the same view (one sample at each pixel's centre), and compares
/// them pixel by pixel (the script's check_mapped action): true when at most `maxDiffering` of
/// the pixels both cover differ by more than 1 % of the peak (float vs double decisions: a
/// shadow or a hit at a prism's edge) and the coverage differs on at most `maxMismatch`.
bool checkMapped(const ObjectView& app, int w, int h, double maxDiffering, double maxMismatch,
                 nlohmann::json* result);
/// What the ParamDecl widget did this frame: `changed` with the new `value`; `merge` when it
/// continues an edit begun on an earlier frame (a drag: one undo step).
struct ParamEdit {
  bool changed = false, merge = false;
  nlohmann::ordered_json value;
};
/// The one widget for a value of a ParamDecl (the scene's parameters, a request's options): a
/// drag within the declared range (Float, Int, vectors), a colour editor (Rgb), a combo of the
/// choices (Enum), a checkbox (Bool), text (String, Path; a Path picks from `pickFolders`); the
/// declaration's doc is the tooltip. The caller commits the value and shows the engine's answer.
ParamEdit paramWidget(const std::string& label, const ParamDecl& d,
                      const nlohmann::ordered_json& value,
                      const std::vector<std::string>& pickFolders = {});
/// A request's option as the widget's value (a number, a flag, text; null when unset).
nlohmann::ordered_json requestValue(const ops::Request& r, const ParamDecl& d);
/// A widget value as a request's text ("12", "0.25", "true", the string itself).
std::string paramText(const ParamDecl& d, const nlohmann::ordered_json& v);
/// One option of a request edited through the ParamDecl widget: drags within the declared range,
/// combos for choices, a checkbox for flags, text for the rest; the doc is the tooltip. A
/// refused value leaves the request as it was and puts the engine's message in `error`.
/// Returns true when the request changed.
bool requestParam(ops::Request& r, const ParamDecl& d, std::string* error);
/// Shader source by file name (embedded at build time; read from BTF_SHADER_DIR when set).
std::string shaderSource(const std::string& name);

}  // namespace btf::ui
