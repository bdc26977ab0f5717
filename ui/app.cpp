#include "app.h"

#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <btf/core/error.h>
#include <btf/core/input_file.h>
#include <btf/core/json_limits.h>
#include <btf/core/sysinfo.h>
#include <btf/io/image_io.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace btf::ui {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

WindowHolder::~WindowHolder() {
  if (window) {
    glfwDestroyWindow(window);
    glfwTerminate();
  }
}

App::App(AppOptions o) : opt(std::move(o)) {
  for (const char* p : {"Scene", "Tile view", "Preview", "BRDF", "Jobs"}) panels[p] = true;
  for (const char* p : {"Inspector", "Objects", "Study"}) panels[p] = false;  // opened on demand
}

App::~App() {
  jobs.cancelAll();
}

void App::message(const std::string& text, bool error) {
  status = text;
  statusIsError = error;
  std::fprintf(error ? stderr : stdout, "btfstudio: %s\n", text.c_str());
}

namespace {
// Recent files live in $XDG_CONFIG_HOME/btfstudio/recent.txt (or ~/.config/...), one per line.
fs::path recentFile() {
  const char* x = std::getenv("XDG_CONFIG_HOME");
  const char* h = std::getenv("HOME");
  if (x && *x) return fs::path(x) / "btfstudio" / "recent.txt";
  if (h && *h) return fs::path(h) / ".config" / "btfstudio" / "recent.txt";
  return {};
}
}  // namespace

void App::loadRecent() {
  const fs::path f = recentFile();
  std::ifstream in(f);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && recent.size() < 8) recent.push_back(line);
}

void App::saveRecent() const {
  if (!m_script.is_null()) return;  // scripted sessions leave the user's settings alone
  const fs::path f = recentFile();
  if (f.empty()) return;
  std::error_code ec;
  fs::create_directories(f.parent_path(), ec);
  const fs::path tmp = f.string() + ".partial";
  {
    std::ofstream out(tmp);
    for (const auto& r : recent) out << r << "\n";
  }
  fs::rename(tmp, f, ec);
}

void App::openScene(const std::string& path) {
  try {
    doc.open(path);
    fieldErrors.clear();
    const std::string abs = fs::absolute(path).lexically_normal().string();
    std::erase(recent, abs);
    recent.insert(recent.begin(), abs);
    if (recent.size() > 8) recent.resize(8);
    saveRecent();
    tile.selectedPart = -1;
    message("opened " + path);
  } catch (const std::exception& e) {
    message(e.what(), true);  // the current scene stays
    throw;
  }
}

void App::saveScene(const std::string& path) {
  doc.save(path);
  message("saved " + path);
}

void App::guardDiscard(std::function<void()> f) {
  if (!doc.dirty() || !m_script.is_null()) {
    f();
    return;
  }
  pendingDiscard = std::move(f);
  confirmDiscard = true;
}

void App::setParam(const std::string& pointer, const nlohmann::ordered_json& value, bool merge) {
  try {
    doc.set(pointer, value, "", merge);
    fieldErrors.erase(pointer);
  } catch (const std::exception& e) {
    fieldErrors[pointer] = e.what();
    message(e.what(), true);
    throw;
  }
}

void App::undo() {
  if (!doc.canUndo()) return;
  message("undo: " + doc.undoLabel());
  doc.undo();
  fieldErrors.clear();
}

void App::redo() {
  if (!doc.canRedo()) return;
  message("redo: " + doc.redoLabel());
  doc.redo();
  fieldErrors.clear();
}

void App::requestPreview() {
  pv.dirty = true;
}

void App::saveScreenshot(const std::string& path) {
  auto px = gl::readBackBuffer(width, height);
  std::vector<float> f(px.size());
  for (size_t i = 0; i < px.size(); ++i) {
    // Undo the sRGB curve so writeRgbImage's PNG encoding gives back the same bytes.
    const float v = px[i] / 255.0f;
    f[i] = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
  }
  fs::create_directories(fs::absolute(path).parent_path());
  writeRgbImage(path, width, height, f, 1.0f, false);
  message("screenshot " + path);
}

void App::handleShortcuts() {
  ImGuiIO& io = ImGui::GetIO();
  if (io.WantTextInput) return;
  const bool ctrl = io.KeyCtrl;
  if (ctrl && ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Z), false)) {
    if (io.KeyShift)
      redo();
    else
      undo();
  }
  if (ctrl && ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Y), false)) redo();
  if (ctrl && ImGui::IsKeyPressed(GLFW_KEY_S, false) && !doc.path().empty()) {
    try {
      saveScene(doc.path().string());
    } catch (const std::exception& e) {
      message(e.what(), true);
    }
  }
}

void App::handleDrop() {
  auto dropped = std::move(m_dropped);
  m_dropped.clear();
  for (const std::string& p : dropped) {
    std::string ext = fs::path(p).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    try {
      if (ext == ".json") {
        guardDiscard([this, p] {
          try {
            openScene(p);
          } catch (const std::exception&) {
          }
        });
      } else if (ext == ".obj" || ext == ".ply" || ext == ".off" || ext == ".stl") {
        // A mesh becomes a new part on the first material.
        const std::string mat = doc.scene().materials.front().name;
        doc.edit("add mesh " + fs::path(p).filename().string(), [&](nlohmann::ordered_json& j) {
          j["parts"].push_back({{"name", fs::path(p).stem().string()},
                                {"type", "mesh"},
                                {"material", mat},
                                {"path", fs::absolute(p).string()}});
        });
        message("added mesh part from " + p);
      } else if (ext == ".png" || ext == ".exr" || ext == ".jpg" || ext == ".tif" ||
                 ext == ".hdr") {
        const std::string mat = doc.scene().materials.front().name;
        doc.edit("add height field " + fs::path(p).filename().string(),
                 [&](nlohmann::ordered_json& j) {
                   j["parts"].push_back({{"name", fs::path(p).stem().string()},
                                         {"type", "heightfield"},
                                         {"material", mat},
                                         {"image", fs::absolute(p).string()}});
                 });
        message("added height-field part from " + p);
      } else if (ext == ".cbtf") {
        openCompressed(p, "");
      } else {
        message(p + ": cannot open this kind of file (scene .json, mesh .obj/.ply, image, .cbtf)",
                true);
      }
    } catch (const std::exception& e) {
      message(p + ": " + e.what(), true);
    }
  }
}

void App::drawMenu() {
  if (!ImGui::BeginMainMenuBar()) return;
  if (ImGui::BeginMenu("File")) {
    if (ImGui::MenuItem("New")) guardDiscard([this] { doc.reset(defaultScene(), {}); });
    if (ImGui::BeginMenu("Open example")) {
      std::vector<std::string> names;
      for (const auto& e : fs::directory_iterator(BTF_RESOURCE_DIR "/scenes"))
        if (e.path().extension() == ".json") names.push_back(e.path().string());
      std::sort(names.begin(), names.end());
      for (const auto& n : names)
        if (ImGui::MenuItem(fs::path(n).stem().string().c_str()))
          guardDiscard([this, n] {
            try {
              openScene(n);
            } catch (const std::exception&) {
            }
          });
      ImGui::EndMenu();
    }
    if (ImGui::BeginMenu("Open recent", !recent.empty())) {
      for (const auto& r : recent)
        if (ImGui::MenuItem(r.c_str()))
          guardDiscard([this, r] {
            try {
              openScene(r);
            } catch (const std::exception&) {
            }
          });
      ImGui::EndMenu();
    }
    if (ImGui::MenuItem("Save", "Ctrl+S", false, !doc.path().empty())) {
      try {
        saveScene(doc.path().string());
      } catch (const std::exception& e) {
        message(e.what(), true);
      }
    }
    if (ImGui::MenuItem("Open…")) m_pathPopup = "Open scene";
    if (ImGui::MenuItem("Save as…")) m_pathPopup = "Save scene as";
    ImGui::Separator();
    if (ImGui::MenuItem("Quit")) guardDiscard([this] { m_quit = true; });
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Edit")) {
    const std::string u = "Undo " + doc.undoLabel(), r = "Redo " + doc.redoLabel();
    if (ImGui::MenuItem(u.c_str(), "Ctrl+Z", false, doc.canUndo())) undo();
    if (ImGui::MenuItem(r.c_str(), "Ctrl+Shift+Z", false, doc.canRedo())) redo();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Panels")) {
    for (auto& [name, open] : panels) ImGui::MenuItem(name.c_str(), nullptr, &open);
    ImGui::EndMenu();
  }
  ImGui::EndMainMenuBar();
}

void App::drawStatusBar() {
  const ImGuiViewport* vp = ImGui::GetMainViewport();
  const float h = ImGui::GetFrameHeight() + 4;
  ImGui::SetNextWindowPos(ImVec2(vp->Pos.x, vp->Pos.y + vp->Size.y - h));
  ImGui::SetNextWindowSize(ImVec2(vp->Size.x, h));
  ImGui::Begin("##status", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove |
                   ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoFocusOnAppearing |
                   ImGuiWindowFlags_NoBringToFrontOnFocus);
  ImGui::Text("frame %.1f ms | objects %.1f ms | %s%s | mem %s |", frameMs, obj.frameMs,
              doc.scene().name.c_str(), doc.dirty() ? " *" : "",
              formatBytes(double(currentRssBytes())).c_str());
  ImGui::SameLine();
  if (statusIsError)
    ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", status.c_str());
  else
    ImGui::TextUnformatted(status.c_str());
  ImGui::End();
}

void App::drawPathPopup() {
  if (!m_pathPopup.empty()) {
    ImGui::OpenPopup(m_pathPopup.c_str());
    m_pathTitle = m_pathPopup;
    if (m_pathInput.empty())
      m_pathInput = doc.path().empty() ? "out/" + doc.scene().name + ".json" : doc.path().string();
    m_pathPopup.clear();
  }
  if (m_pathTitle.empty()) return;
  if (ImGui::BeginPopupModal(m_pathTitle.c_str(), nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::SetNextItemWidth(420);
    const bool enter = ImGui::InputText("path", &m_pathInput, ImGuiInputTextFlags_EnterReturnsTrue);
    if (ImGui::Button("OK") || enter) {
      const std::string p = m_pathInput, title = m_pathTitle;
      ImGui::CloseCurrentPopup();
      m_pathTitle.clear();
      if (title == "Open scene") {
        guardDiscard([this, p] {
          try {
            openScene(p);
          } catch (const std::exception&) {
          }
        });
      } else {
        try {
          const fs::path parent = fs::absolute(p).parent_path();
          fs::create_directories(parent);
          saveScene(p);
        } catch (const std::exception& e) {
          message(e.what(), true);
        }
      }
    }
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) {
      ImGui::CloseCurrentPopup();
      m_pathTitle.clear();
    }
    ImGui::EndPopup();
  }
}

void App::drawDiscardPrompt() {
  if (confirmDiscard) {
    ImGui::OpenPopup("Unsaved changes");
    confirmDiscard = false;
  }
  if (ImGui::BeginPopupModal("Unsaved changes", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("The scene '%s' has unsaved changes.", doc.scene().name.c_str());
    if (ImGui::Button("Discard them")) {
      auto f = std::move(pendingDiscard);
      pendingDiscard = nullptr;
      ImGui::CloseCurrentPopup();
      if (f) f();
    }
    ImGui::SameLine();
    if (ImGui::Button("Keep editing")) {
      pendingDiscard = nullptr;
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
}

void App::frame() {
  // Preview requests follow every scene or direction change.
  if (doc.revision() != pv.requestedRevision) pv.dirty = true;
  const bool analysis = panels["BRDF"];
  if (analysis && !pv.requestedAnalysis) pv.dirty = true;  // opened: its stages are due
  if (pv.dirty) {
    PreviewRequest r;
    r.sceneJson = doc.json();
    r.source = doc.scene().source;
    r.baseDir = doc.scene().baseDir;
    r.thetaV = pv.thetaV;
    r.phiV = pv.phiV;
    r.thetaL = pv.thetaL;
    r.phiL = pv.phiL;
    r.size = pv.size;
    r.texelU = pv.texelU;
    r.texelV = pv.texelV;
    r.brdf = r.matrix = analysis;
    pv.requestedAnalysis = analysis;
    pv.generation = preview.request(r);
    pv.requestedRevision = doc.revision();
    pv.requestTime = Clock::now();
    pv.firstImageSeconds = -1;
    pv.dirty = false;
  }
  updatePreview(previewView());
  jobs.pump();
  handleDrop();
  handleShortcuts();

  drawMenu();
  const ImGuiViewport* vp = ImGui::GetMainViewport();
  const float top = ImGui::GetFrameHeight();
  const float W = vp->Size.x, H = vp->Size.y - top - ImGui::GetFrameHeight() - 4;
  // Default layout: editor left, views in the middle column, analysis right.
  auto place = [&](float x, float y, float w, float h) {
    ImGui::SetNextWindowPos(ImVec2(x * W, top + y * H), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(w * W, h * H), ImGuiCond_FirstUseEver);
  };
  auto panel = [&](const char* name, float x, float y, float w, float h,
                   const std::function<void()>& draw) {
    if (!panels[name]) return;
    place(x, y, w, h);
    if (focusPanel == name) {
      ImGui::SetNextWindowFocus();
      ImGui::SetNextWindowCollapsed(false);
    }
    draw();
  };
  // Each panel gets a view of what it uses (panels/panels.h), not the App.
  panel("Scene", 0, 0, 0.24f, 1, [&] { drawScenePanel(sceneView()); });
  panel("Tile view", 0.24f, 0, 0.38f, 0.5f, [&] { drawTileView(tileView()); });
  panel("Preview", 0.62f, 0, 0.38f, 0.5f, [&] { drawPreviewPanel(previewView()); });
  panel("BRDF", 0.24f, 0.5f, 0.38f, 0.5f, [&] { drawBrdfPanel(brdfView()); });
  panel("Jobs", 0.62f, 0.5f, 0.38f, 0.5f, [&] { drawJobsPanel(jobsView()); });
  panel("Inspector", 0.3f, 0.1f, 0.6f, 0.8f, [&] { drawInspectorPanel(inspectorView()); });
  panel("Objects", 0.35f, 0.05f, 0.55f, 0.8f, [&] { drawObjectViewer(objectView()); });
  panel("Study", 0.4f, 0.2f, 0.5f, 0.6f, [&] { drawStudyPanel(studyView()); });
  focusPanel.clear();
  drawDiscardPrompt();
  drawPathPopup();
  drawStatusBar();
}

void App::loadFont() {
  // DejaVu Sans (fonts-dejavu-core) for θ, φ, ², ×, — and arrows; ImGui's built-in font is ASCII.
  const char* path = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
  if (!fs::exists(path)) return;
  static const ImWchar ranges[] = {0x0020, 0x00FF, 0x0370, 0x03FF, 0x2000, 0x206F, 0x2070,
                                   0x209F, 0x2190, 0x21FF, 0x2200, 0x22FF, 0};
  ImGui::GetIO().Fonts->AddFontFromFileTTF(path, 14.0f, nullptr, ranges);
}

int App::run() {
  if (!opt.script.empty()) {
    checkInputFile(opt.script, "script", uint64_t(16) << 20, "16 MiB");
    std::ifstream f(opt.script, std::ios::binary);
    if (!f) throw Error(opt.script + ": cannot open script");
    std::stringstream text;
    text << f.rdbuf();
    m_script = parseJsonText(text.str(), opt.script);
    if (m_script.is_object() && m_script.contains("actions")) m_script = m_script["actions"];
    if (!m_script.is_array()) throw Error(opt.script + ": expected a list of actions");
  }
  if (m_script.is_null()) loadRecent();
  if (!opt.scene.empty()) openScene(opt.scene);
  m_originalJson = doc.json();

  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!display || !*display) && (!wayland || !*wayland))
    throw Error(
        "no display: btfstudio needs an X or Wayland display (DISPLAY is not set). On a headless "
        "machine run it under Xvfb: xvfb-run -a -s \"-screen 0 1280x800x24\" btfstudio ... — "
        "or use btfsim, the headless command line");
  glfwSetErrorCallback([](int code, const char* text) {
    std::fprintf(stderr, "btfstudio: GLFW error %d: %s\n", code, text);
  });
  if (!glfwInit())
    throw Error("cannot initialise GLFW (no usable display '" +
                std::string(display ? display : "") + "'): run under xvfb-run for headless use");
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  m_window = glfwCreateWindow(opt.width, opt.height, "BTF Studio", nullptr, nullptr);
  if (!m_window) {
    glfwTerminate();
    throw Error("cannot create an OpenGL 3.3 core window on this display");
  }
  glfwMakeContextCurrent(m_window);
  glfwSwapInterval(m_script.is_null() && opt.screenshot.empty() ? 1 : 0);
  glfwSetWindowUserPointer(m_window, this);
  glfwSetWindowCloseCallback(m_window, [](GLFWwindow* w) {
    // Closing the window with unsaved changes asks first, like File → Quit.
    auto* app = static_cast<App*>(glfwGetWindowUserPointer(w));
    if (app->doc.dirty() && app->m_script.is_null()) {
      glfwSetWindowShouldClose(w, GLFW_FALSE);
      app->guardDiscard([app] { app->m_quit = true; });
    }
  });
  glfwSetDropCallback(m_window, [](GLFWwindow* w, int n, const char** paths) {
    auto* app = static_cast<App*>(glfwGetWindowUserPointer(w));
    for (int i = 0; i < n; ++i) app->m_dropped.push_back(paths[i]);
  });
  glInfo = gl::contextDescription();
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // a fixed layout: screenshots are reproducible
  ImGui::StyleColorsDark();
  loadFont();
  ImGui_ImplGlfw_InitForOpenGL(m_window, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  message("ready — " + glInfo);

  int settled = 0;
  auto last = Clock::now();
  std::string title;
  while (!glfwWindowShouldClose(m_window) && !m_quit) {
    // A script or a screenshot run draws as fast as it needs (its own pacing, below); a user's
    // session waits for events while nothing changes on its own.
    const bool interactive = (m_script.is_null() && opt.screenshot.empty()) ||
                             Clock::now() < m_interactiveUntil;
    if (interactive) {
      last += waitForEvents();  // the frame time shown is drawing, not waiting for events
    } else {
      glfwPollEvents();
    }
    const std::string t = "BTF Studio — " + doc.scene().name + (doc.dirty() ? " *" : "") +
                          (doc.path().empty() ? "" : " (" + doc.path().string() + ")");
    if (t != title) glfwSetWindowTitle(m_window, (title = t).c_str());
    glfwGetFramebufferSize(m_window, &width, &height);
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    frame();
    ImGui::Render();
    gl::Framebuffer::end(width, height);
    glClearColor(0.1f, 0.1f, 0.12f, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (!m_screenshotPending.empty()) {
      try {
        saveScreenshot(m_screenshotPending);
      } catch (const std::exception& e) {
        message(e.what(), true);
        m_exitStatus = 1;
        m_quit = true;
      }
      m_screenshotPending.clear();
    }
    if (!opt.screenshot.empty() && m_script.is_null()) {
      // Wait for the preview to finish (bounded) so the screenshot shows it.
      if (++settled > 3 && (!preview.working() || settled > 600)) {
        saveScreenshot(opt.screenshot);
        m_quit = true;
      }
    }
    glfwSwapBuffers(m_window);
    const auto now = Clock::now();
    frameMs = std::chrono::duration<double, std::milli>(now - last).count();
    last = now;
    frameHistory.push_back(frameMs);
    ++m_frames;
    if (frameHistory.size() > 240) frameHistory.pop_front();
    if (!m_script.is_null() && !scriptStep()) m_quit = true;
    // A script waiting on a job or the preview worker draws ten frames a second, not as many as
    // the CPU renders: a software-rendered frame costs as much as the worker's own work.
    if (m_waitOnJob && m_waitFor)
      std::this_thread::sleep_until(now + std::chrono::milliseconds(100));
  }
  jobs.cancelAll();
  jobs.waitAll(5);
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  return m_exitStatus;  // the window goes with the App, after its GL objects
}

bool App::passRuns() const {
  const auto o = panels.find("Objects");
  return obj.band >= 0 && o != panels.end() && o->second;
}

Clock::duration App::waitForEvents() {
  // After an event ImGui needs a few frames to settle (hover, layout, popups); an object pass
  // draws a band a frame; a job or the preview worker changes what the panels show ten times a
  // second at most; otherwise the studio sleeps until an event (or half a second: messages that
  // time out, a file dropped).
  if (m_settleFrames > 0 || passRuns() || !m_screenshotPending.empty()) {
    if (m_settleFrames > 0) --m_settleFrames;
    glfwPollEvents();
    return Clock::duration::zero();
  }
  const double timeout = jobs.busy() || preview.working() ? 0.1 : 0.5;
  const auto t0 = Clock::now();
  glfwWaitEventsTimeout(timeout);
  const Clock::duration waited = Clock::now() - t0;
  if (std::chrono::duration<double>(waited).count() < 0.9 * timeout)
    m_settleFrames = 3;  // woken by an event
  return waited;
}

SceneView App::sceneView() {
  return {panels["Scene"], doc, fieldErrors, tile, *this};
}
TileViewView App::tileView() {
  return {panels["Tile view"], doc, pv, tile, width, height, *this};
}
PreviewView App::previewView() {
  return {panels["Preview"], preview, pv, *this};
}
BrdfView App::brdfView() {
  return {panels["BRDF"], pv};
}
JobsView App::jobsView() {
  return {panels["Jobs"], doc, form, jobs, *this};
}
InspectorView App::inspectorView() {
  return {panels["Inspector"], insp, pv, *this};
}
ObjectView App::objectView() {
  return {panels["Objects"], obj, insp, width, height, *this};
}
StudyView App::studyView() {
  return {panels["Study"], study, *this};
}

}  // namespace btf::ui
