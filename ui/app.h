// The studio application: window, frame loop, the panels' shared state, and the script runner
// (`btfstudio --script`). Panels live one per file in ui/panels/ and draw from this state; only
// ui/gl/ calls GL.
#pragma once
#include <btf/compress/compress.h>
#include <btf/sim/study.h>

#include <chrono>
#include <deque>
#include <future>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "document.h"
#include "gl/gl.h"
#include "job_requests.h"
#include "jobs.h"
#include "panel_state.h"
#include "panels/panels.h"
#include "preview.h"
#include "studio_actions.h"

struct GLFWwindow;

namespace btf::ui {

struct AppOptions {
  std::string scene;       // opened at start ("" = the built-in default scene)
  std::string script;      // JSON list of actions; the app exits when it ends
  std::string screenshot;  // saved after the first settled frame; then exit
  int width = 1280, height = 800;
};

/// Owns the window; declared first in App so it is destroyed last, after every GL object.
struct WindowHolder {
  GLFWwindow* window = nullptr;
  ~WindowHolder();
};

class App : public StudioActions {
  WindowHolder m_holder;

 public:
  explicit App(AppOptions o);
  ~App();
  /// Creates the window and runs until closed or the script ends; returns the exit status.
  int run();

  // Shared state the panels use.
  AppOptions opt;
  Document doc;
  JobQueue jobs;
  PreviewWorker preview;
  PreviewState pv;
  InspectorState insp;
  ObjectState obj;
  TileViewState tile;
  StudyState study;
  JobForm form;
  std::vector<std::string> recent;
  std::map<std::string, std::string> fieldErrors;  // JSON pointer → engine error
  std::string status;                              // last message in the status bar
  bool statusIsError = false;
  std::map<std::string, bool> panels;  // name → open
  std::string focusPanel;              // brought to front on the next frame
  int width = 0, height = 0;
  double frameMs = 0, frameMsMax = 0;
  std::deque<double> frameHistory;  // ms, the last 240 frames
  std::string glInfo;
  bool confirmDiscard = false;  // the unsaved-changes prompt is open
  std::function<void()> pendingDiscard;

  // Actions shared by menus, shortcuts and scripts (errors become status messages).
  void message(const std::string& text, bool error = false) override;
  void openScene(const std::string& path);
  void saveScene(const std::string& path);
  /// Runs `f` now if the document is clean, else after the unsaved-changes prompt.
  void guardDiscard(std::function<void()> f);
  void setParam(const std::string& pointer, const nlohmann::ordered_json& value,
                bool merge = false) override;
  void undo() override;
  void redo() override;
  int startSimulation(const std::string& output, bool compressToo) override;
  int startCompression(const std::string& input, const std::string& output) override;
  /// Simulation streamed into the form's codec (no raw file), as `btfsim simulate --compress`.
  int startStreamedSimulation(const std::string& output) override;
  int startStudy(const std::string& dir) override;
  int startExport(const std::string& input, const std::string& format,
                  const std::string& output) override;
  void openCompressed(const std::string& path, const std::string& reference) override;
  int startObjectRender(const std::string& mode, int spp, int size,
                        const std::string& output = "") override;
  void compareInspector() override;
  /// Compresses the reference with every codec at the form's target ratio and compares each:
  /// one row per codec in the inspector's table. Returns the last job id.
  int startCodecSweep(const std::string& reference) override;
  void loadStudy(const std::string& dir) override;
  /// Estimate of a simulation of the current scene with the form's settings (one line).
  std::string simulationEstimate() override;

  void requestPreview() override;
  /// Facts the script's report records (panel rectangles, latencies); panels write here.
  nlohmann::json& report() override { return m_report; }
  void saveScreenshot(const std::string& path);

 private:
  std::string estimateCache;
  std::string estimateKey;
  std::future<std::string> m_estimate;
  // What each panel is handed (panels/panels.h).
  SceneView sceneView();
  TileViewView tileView();
  PreviewView previewView();
  BrdfView brdfView();
  JobsView jobsView();
  InspectorView inspectorView();
  ObjectView objectView();
  StudyView studyView();
  void frame();
  void loadFont();
  void drawMenu();
  void drawStatusBar();
  void drawDiscardPrompt();
  void drawPathPopup();
  void loadRecent();
  void saveRecent() const;
  std::string m_pathPopup, m_pathTitle, m_pathInput;
  void handleShortcuts();
  void handleDrop();
  bool scriptStep();  // false when the script has ended
  // Interactive pacing: waits for events while nothing changes on its own; returns how long.
  std::chrono::steady_clock::duration waitForEvents();
  bool passRuns() const;   // the Objects panel is open and its pass is being drawn
  int m_settleFrames = 3;  // frames still drawn at full rate after an event
  // A script's {"interactive": seconds}: the interactive pacing until then (its test).
  std::chrono::steady_clock::time_point m_interactiveUntil{};
  GLFWwindow*& m_window = m_holder.window;
  nlohmann::json m_script;
  size_t m_scriptPos = 0;
  int m_scriptWaitFrames = 0;
  uint64_t m_frames = 0;  // frames drawn since start (BTF_SCRIPT_TIMING prints them per action)
  std::chrono::steady_clock::time_point m_waitUntil{};
  std::function<bool()> m_waitFor;  // true when the wait is over
  // The wait is on a background job: frames are spaced (scriptFrameSpacing) so that drawing
  // them (llvmpipe under Xvfb) does not take the cores from the job.
  bool m_waitOnJob = false;
  std::chrono::steady_clock::time_point m_waitDeadline{};
  std::string m_waitWhat;
  int m_exitStatus = 0;
  bool m_quit = false;
  std::vector<std::string> m_dropped;
  std::string m_originalJson;  // scene JSON when the script last opened a scene
  nlohmann::json m_report = nlohmann::json::object();
  std::string m_screenshotPending;
  int m_lastJobId = 0;
};

}  // namespace btf::ui
