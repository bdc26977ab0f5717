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
#include "preview.h"

struct GLFWwindow;

namespace btf::ui {

struct AppOptions {
  std::string scene;       // opened at start ("" = the built-in default scene)
  std::string script;      // JSON list of actions; the app exits when it ends
  std::string screenshot;  // saved after the first settled frame; then exit
  int width = 1280, height = 800;
};

// --- per-panel state -------------------------------------------------------------------------

struct PreviewState {
  double thetaV = 0, phiV = 0, thetaL = 30, phiL = 0;  // degrees
  int size = 64;
  int texelU = -1, texelV = -1;  // picked texel (-1: centre)
  float exposure = 1;
  bool logScale = false;
  bool tileAverage = true;  // BRDF hemisphere: tile average (else the picked texel)
  uint64_t requestedRevision = ~0ull, generation = 0;
  bool dirty = true;  // a new request is due
  std::chrono::steady_clock::time_point requestTime;
  double firstImageSeconds = -1;  // latency of the last request's first image
  PreviewResult result;
  uint64_t stamp = 0, imageStamp = ~0ull, brdfStamp = ~0ull;  // results polled / uploaded
  gl::Texture image, hemisphere, matrix;
};

struct InspectorState {
  std::string compressed, reference;  // .cbtf and the raw store it came from
  std::shared_ptr<CompressedBtf> cbtf;
  // Shared: a running comparison keeps the decoders it reads even if another file is opened.
  std::shared_ptr<const Decoder> decoder, refDecoder;
  std::string header;  // codec, ratio, components (one paragraph)
  double ratio = 0;
  bool haveReport = false;
  ErrorReport report;
  int comparing = 0;  // job id of a running comparison
  int view = 0, light = 0;
  gl::Texture texelMap, dirMap, original, reconstructed, difference;
  bool texturesDirty = true;
  struct Row {
    std::string codec;
    double ratio, rmse, relRmse, psnr;
  };
  std::vector<Row> codecs;  // one row per compared file
};

struct ObjectState {
  std::string shape = "sphere";  // plane | sphere | cylinder | vase | cushion | chair
  std::string loadedShape;
  gl::Mesh mesh;
  float yaw = 0.6f, pitch = 0.5f, distance = 3.2f;
  float lightTheta = 40, lightPhi = 30;  // degrees, in the camera's frame
  float exposure = 1.5f, tiling = 2;
  int toneMap = 1;
  bool bilinear = true;
  gl::Framebuffer fb;
  gl::Program program;
  std::string programError;
  std::vector<std::unique_ptr<gl::TextureBuffer>> buffers;  // bound arrays of the decoder
  std::string bound;                                        // path of the bound file
  double frameMs = 0;  // GPU-inclusive time of the last object pass (rendered on change only)
  float renderScale = 0.5f;
  std::string renderedKey;
  int bands = 16;  // bands of rows per pass, sized from the last pass to ~20 ms a frame
  int band = -1;   // next band to render; -1 when the pass is complete
  double passMs = 0;
};

struct TileViewState {
  float yaw = 0.8f, pitch = 0.9f, distance = 3.5f;
  int selectedPart = -1;
  uint64_t builtRevision = ~0ull;
  std::string error;
  gl::Mesh mesh, outline, lightLine;
  gl::Program program, lines;
  gl::Framebuffer fb, pick;
  float Lx = 1, Ly = 1, zmin = 0, zmax = 0;
  std::vector<std::array<float, 3>> partColours;
};

struct StudyState {
  std::string dir;  // folder of study.csv
  struct Point {
    std::string label;
    double seconds, error;
    bool pareto;
  };
  std::vector<Point> points;
  std::string chosen;  // label of the configuration matching the scene's settings
  std::string error;
};

/// Owns the window; declared first in App so it is destroyed last, after every GL object.
struct WindowHolder {
  GLFWwindow* window = nullptr;
  ~WindowHolder();
};

class App {
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
  void message(const std::string& text, bool error = false);
  void openScene(const std::string& path);
  void saveScene(const std::string& path);
  /// Runs `f` now if the document is clean, else after the unsaved-changes prompt.
  void guardDiscard(std::function<void()> f);
  void setParam(const std::string& pointer, const nlohmann::ordered_json& value,
                bool merge = false);
  void undo();
  void redo();
  int startSimulation(const std::string& output, bool compressToo);
  int startCompression(const std::string& input, const std::string& output);
  /// Simulation streamed into the form's codec (no raw file), as `btfsim simulate --compress`.
  int startStreamedSimulation(const std::string& output);
  int startStudy(const std::string& dir);
  int startExport(const std::string& input, const std::string& format, const std::string& output);
  void openCompressed(const std::string& path, const std::string& reference);
  void compareInspector();
  /// Compresses the reference with every codec at the form's target ratio and compares each:
  /// one row per codec in the inspector's table. Returns the last job id.
  int startCodecSweep(const std::string& reference);
  void loadStudy(const std::string& dir);
  /// Estimate of a simulation of the current scene with the form's settings (one line).
  std::string simulationEstimate();
  std::string estimateCache;
  std::string estimateKey;
  std::future<std::string> m_estimate;

  void requestPreview();
  /// Facts the script's report records (panel rectangles, latencies); panels write here.
  nlohmann::json& report() { return m_report; }
  void saveScreenshot(const std::string& path);

 private:
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
  GLFWwindow*& m_window = m_holder.window;
  nlohmann::json m_script;
  size_t m_scriptPos = 0;
  int m_scriptWaitFrames = 0;
  std::chrono::steady_clock::time_point m_waitUntil{};
  std::function<bool()> m_waitFor;  // true when the wait is over
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

// Panels (ui/panels/*.cpp).
void updatePreview(App& app);  // polls the worker, uploads textures (every frame)
void drawScenePanel(App& app);
void drawTileView(App& app);
void drawPreviewPanel(App& app);
void drawBrdfPanel(App& app);
void drawJobsPanel(App& app);
/// Renders the GLSL decoder into a float target at `samples` random (x, y, ωi, ωo) and compares
/// with the CPU decoder (object_viewer.cpp; the script's check_glsl action).
bool checkGlsl(App& app, int samples, double tolerance, nlohmann::json* result);
void drawInspectorPanel(App& app);
void drawObjectViewer(App& app);
void drawStudyPanel(App& app);

/// Shader source by file name (embedded at build time; read from BTF_SHADER_DIR when set).
std::string shaderSource(const std::string& name);

}  // namespace btf::ui
