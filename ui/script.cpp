// `btfstudio --script FILE.json`: a list of UI actions run one per frame through the same code
// paths as the menus and panels; the first failing action prints why and sets exit status 1.
// Actions and their keys are documented in docs/studio.md.
#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/io/image_io.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>

#include "app.h"

namespace btf::ui {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ojson = nlohmann::ordered_json;

ojson ordered(const json& j) {
  return ojson::parse(j.dump());
}
using Clock = std::chrono::steady_clock;

namespace {

// One random edit of the scene's numeric parameters (the random undo/redo test).
bool randomEdit(Document& doc, std::mt19937_64& rng) {
  const json j = json::parse(doc.json());
  std::vector<std::pair<std::string, json>> leaves;
  std::function<void(const json&, const std::string&)> walk = [&](const json& v,
                                                                  const std::string& p) {
    if (v.is_object())
      for (auto it = v.begin(); it != v.end(); ++it) walk(it.value(), p + "/" + it.key());
    else if (v.is_array() && !v.empty() && !v[0].is_number())
      for (size_t i = 0; i < v.size(); ++i) walk(v[i], p + "/" + std::to_string(i));
    else if (v.is_number_float() || (v.is_array() && !v.empty() && v[0].is_number_float()))
      leaves.push_back({p, v});
  };
  walk(j, "");
  std::erase_if(leaves, [](const auto& l) {
    return l.first.find("/simulation") == 0 || l.first.find("/tile") == 0;
  });
  if (leaves.empty()) return false;
  const auto& [ptr, val] = leaves[rng() % leaves.size()];
  std::uniform_real_distribution<double> f(0.9, 1.1);
  json next = val;
  if (next.is_array())
    for (auto& x : next) x = double(x) * f(rng);
  else
    next = double(next) * f(rng);
  try {
    doc.set(ptr, ordered(next));
    return true;
  } catch (const Error&) {
    return false;  // out of range: the engine refused it, the scene is unchanged
  }
}

}  // namespace

bool App::scriptStep() {
  if (m_scriptWaitFrames > 0) {
    --m_scriptWaitFrames;
    return true;
  }
  if (Clock::now() < m_waitUntil) return true;
  if (m_waitFor) {
    if (!m_waitFor()) {
      if (Clock::now() > m_waitDeadline) {
        message("script: timed out waiting for " + m_waitWhat, true);
        m_exitStatus = 1;
        return false;
      }
      return true;
    }
    m_waitFor = nullptr;
    m_waitOnJob = false;
  }
  if (m_scriptPos >= m_script.size()) {
    if (!m_report.empty() && m_report.contains("_path")) {
      m_report["frames_drawn"] = m_frames;
      m_report["tile_view_draws"] = tile.draws;
      std::ofstream f(m_report["_path"].get<std::string>());
      f << m_report.dump(2) << "\n";
    }
    return false;
  }
  const json& a = m_script[m_scriptPos];
  const std::string where = opt.script + ": action " + std::to_string(m_scriptPos + 1);
  // BTF_SCRIPT_TIMING=1: when each action starts (where a long scripted test spends its time).
  static const bool timing = std::getenv("BTF_SCRIPT_TIMING") != nullptr;
  static const auto scriptStart = Clock::now();
  static uint64_t framesBefore = 0;
  if (timing)
    std::fprintf(stderr, "script timing: action %zu (%s) at %.2f s, %llu frames before it\n",
                 m_scriptPos + 1, a.is_object() && !a.empty() ? a.begin().key().c_str() : "?",
                 std::chrono::duration<double>(Clock::now() - scriptStart).count(),
                 static_cast<unsigned long long>(m_frames - framesBefore));
  framesBefore = m_frames;
  ++m_scriptPos;
  auto fail = [&](const std::string& why) {
    message(where + ": " + why, true);
    m_exitStatus = 1;
    return false;
  };
  auto waitFor = [&](std::function<bool()> f, double seconds, const std::string& what,
                     bool onJob = false) {
    m_waitFor = std::move(f);
    m_waitOnJob = onJob;
    m_waitDeadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double>(seconds));
    m_waitWhat = what;
  };
  auto str = [&](const char* k, const std::string& def = "") {
    return a.contains(k) ? a[k].get<std::string>() : def;
  };
  bool handled = false;
  try {
    if (!a.is_object()) return fail("expected an object like {\"open\": \"scene.json\"}");
    // One named handler per action (docs/studio.md lists them): the first key of the action
    // that names a handler runs it; a handler returns a value to end the step early.
    const std::vector<std::pair<const char*, std::function<std::optional<bool>()>>> handlers = {
        {"open",
         [&]() -> std::optional<bool> {
           openScene(a["open"].get<std::string>());
           m_originalJson = doc.json();
           return std::nullopt;
         }},
        {"new",
         [&]() -> std::optional<bool> {
           doc.reset(defaultScene(), {});
           m_originalJson = doc.json();
           return std::nullopt;
         }},
        {"set",
         [&]() -> std::optional<bool> {
           const std::string ptr = a["set"];
           if (a.contains("expect_error")) {
             const std::string before = doc.json();
             try {
               setParam(ptr, ordered(a.at("value")));
             } catch (const Error& e) {
               if (std::string(e.what()).find(a["expect_error"].get<std::string>()) ==
                   std::string::npos)
                 return fail(std::string("error '") + e.what() + "' does not mention '" +
                             a["expect_error"].get<std::string>() + "'");
               if (doc.json() != before) return fail("a refused edit changed the scene");
               m_scriptWaitFrames = 1;
               return true;
             }
             return fail("setting " + ptr + " was expected to fail");
           }
           setParam(ptr, ordered(a.at("value")));
           return std::nullopt;
         }},
        {"undo",
         [&]() -> std::optional<bool> {
           for (int i = 0; i < a["undo"].get<int>(); ++i) undo();
           return std::nullopt;
         }},
        {"redo",
         [&]() -> std::optional<bool> {
           for (int i = 0; i < a["redo"].get<int>(); ++i) redo();
           return std::nullopt;
         }},
        {"expect_original",
         [&]() -> std::optional<bool> {
           if (doc.json() != m_originalJson)
             return fail("the scene differs from the one opened (undo did not restore it)");
           return std::nullopt;
         }},
        {"random_edits",
         [&]() -> std::optional<bool> {
           const json& r = a["random_edits"];
           std::mt19937_64 rng(r.value("seed", 1));
           const std::string start = doc.json();
           int made = 0;
           for (int i = 0; i < r.value("count", 100); ++i) made += randomEdit(doc, rng);
           const std::string end = doc.json();
           const size_t depth = doc.undoDepth();
           for (size_t i = 0; i < depth; ++i) doc.undo();
           if (doc.json() != start)
             return fail("undoing every random edit did not restore the scene");
           for (size_t i = 0; i < depth; ++i) doc.redo();
           if (doc.json() != end)
             return fail("redoing every random edit did not give the same scene");
           for (size_t i = 0; i < depth; ++i) doc.undo();  // leave the scene as it was
           m_report["random_edits"] = {{"made", made}, {"undo_depth", depth}};
           return std::nullopt;
         }},
        {"directions",
         [&]() -> std::optional<bool> {
           const json& d = a["directions"];
           if (d.contains("view")) pv.thetaV = d["view"][0], pv.phiV = d["view"][1];
           if (d.contains("light")) pv.thetaL = d["light"][0], pv.phiL = d["light"][1];
           if (d.contains("size")) pv.size = d["size"];
           requestPreview();
           return std::nullopt;
         }},
        {"texel",
         [&]() -> std::optional<bool> {
           pv.texelU = a["texel"][0];
           pv.texelV = a["texel"][1];
           requestPreview();
           return std::nullopt;
         }},
        {"wait_preview",
         [&]() -> std::optional<bool> {
           // "stage": "image" stops at the preview image with every effect of the plan (the
           // BRDF slice and the texel matrix may still be running); absent: every stage.
           const std::string stage = a.value("stage", std::string("all"));
           if (stage != "all" && stage != "image")
             return fail("wait_preview: stage '" + stage + "' is not one of all, image");
           const bool imageOnly = stage == "image";
           waitFor(
               [this, imageOnly] {
                 if (pv.dirty || pv.result.generation != pv.generation) return false;
                 if (!(imageOnly ? pv.result.imageFinal || pv.result.done : pv.result.done))
                   return false;
                 m_report["preview_first_image_ms"].push_back(pv.firstImageSeconds * 1e3);
                 m_report["preview_all_stages_ms"].push_back(pv.result.imageSeconds * 1e3);
                 return true;
               },
               a["wait_preview"].get<double>(), "the preview", true);  // a worker's job
           return std::nullopt;
         }},
        {"save_preview",
         [&]() -> std::optional<bool> {
           const auto& r = pv.result;
           if (r.image.empty()) return fail("no preview image yet");
           writeRgbImage(a["save_preview"], r.nu, r.nv, r.image, 1.0f);
           m_report["preview"] = {
               {"stage", r.stage}, {"size", r.nu}, {"first_image_ms", pv.firstImageSeconds * 1e3}};
           return std::nullopt;
         }},
        {"save_brdf",
         [&]() -> std::optional<bool> {
           const auto& r = pv.result;
           if (r.brdfValues.empty()) return fail("no BRDF slice yet");
           json pairs = json::array(), vals = json::array();
           for (size_t k = 0; k < r.brdfPairs.size(); ++k) {
             pairs.push_back(r.brdfPairs[k]);
             vals.push_back({r.brdfValues[k].x, r.brdfValues[k].y, r.brdfValues[k].z});
           }
           std::ofstream f(a["save_brdf"].get<std::string>());
           f << json{{"samples", r.brdfSamples}, {"pairs", pairs}, {"values", vals}}.dump() << "\n";
           return std::nullopt;
         }},
        {"simulate",
         [&]() -> std::optional<bool> {
           const json& s = a["simulate"];
           if (s.contains("texels")) form.sim.set("texels", std::to_string(s["texels"].get<int>()));
           if (s.contains("directions")) form.sim.set("dirs", s["directions"].get<std::string>());
           if (s.contains("spp")) form.sim.set("spp", s["spp"].get<double>());
           if (s.contains("memory_budget"))
             form.sim.set("memory_budget", s["memory_budget"].get<std::string>());
           if (s.contains("threads")) form.threads = s["threads"].get<int>();
           if (s.contains("target_ratio")) form.targetRatio = s["target_ratio"].get<double>();
           form.codec = s.value("codec", form.codec);
           form.resume = s.value("resume", true);
           m_lastJobId = s.value("stream", false)
                             ? startStreamedSimulation(s.at("output"))
                             : startSimulation(s.at("output"), s.value("compress", false));
           if (a.value("wait", 0.0) > 0)
             waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(),
                     "the simulation", true);
           return std::nullopt;
         }},
        {"compress",
         [&]() -> std::optional<bool> {
           const json& s = a["compress"];
           form.codec = s.value("codec", form.codec);
           form.targetRatio = s.value("target_ratio", form.targetRatio);
           form.codecOptions.setFlag("mip", s.value("mip", false));
           m_lastJobId = startCompression(s.at("input"), s.at("output"));
           if (a.value("wait", 0.0) > 0)
             waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(),
                     "the compression", true);
           return std::nullopt;
         }},
        {"study",
         [&]() -> std::optional<bool> {
           m_lastJobId = startStudy(a["study"].at("dir"));
           if (a.value("wait", 0.0) > 0)
             waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(),
                     "the study", true);
           return std::nullopt;
         }},
        {"export",
         [&]() -> std::optional<bool> {
           const json& s = a["export"];
           m_lastJobId = startExport(s.at("input"), s.at("format"), s.at("output"));
           if (a.value("wait", 0.0) > 0)
             waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(),
                     "the export", true);
           return std::nullopt;
         }},
        {"render_objects",
         [&]() -> std::optional<bool> {
           const json& s = a["render_objects"];
           if (s.contains("relief_scale")) obj.reliefScale = s["relief_scale"].get<float>();
           m_lastJobId = startObjectRender(s.value("mode", "all"), s.value("spp", 4),
                                           s.value("size", 256), s.value("output", ""));
           if (a.value("wait", 0.0) > 0)
             waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(),
                     "the render", true);
           return std::nullopt;
         }},
        {"cancel",
         [&]() -> std::optional<bool> {
           auto j = jobs.find(m_lastJobId);
           if (!j) return fail("no job to cancel");
           const auto t0 = Clock::now();
           jobs.cancel(m_lastJobId);
           waitFor(
               [this, j, t0] {
                 const JobStatus st = j->status.load();
                 if (st == JobStatus::Queued || st == JobStatus::Running) return false;
                 m_report["cancel_seconds"] =
                     std::chrono::duration<double>(Clock::now() - t0).count();
                 return true;
               },
               a.value("within", 1.0) + 0.25, "the cancelled job to stop");
           return std::nullopt;
         }},
        {"wait_jobs",
         [&]() -> std::optional<bool> {
           waitFor([this] { return !jobs.busy(); }, a["wait_jobs"].get<double>(),
                     "the jobs", true);
           return std::nullopt;
         }},
        {"expect_job",
         [&]() -> std::optional<bool> {
           auto j = jobs.find(m_lastJobId);
           if (!j) return fail("no job");
           const json& e = a["expect_job"];
           const std::string st = jobStatusName(j->status.load());
           if (e.contains("status") && e["status"] != st)
             return fail("job " + j->title + " is " + st + ", expected " +
                         e["status"].get<std::string>() + " (" + j->message + ")");
           if (e.contains("message") &&
               j->message.find(e["message"].get<std::string>()) == std::string::npos)
             return fail("job message '" + j->message + "' lacks '" +
                         e["message"].get<std::string>() + "'");
           return std::nullopt;
         }},
        {"expect_missing",
         [&]() -> std::optional<bool> {
           if (fs::exists(a["expect_missing"].get<std::string>()))
             return fail(a["expect_missing"].get<std::string>() + " exists");
           return std::nullopt;
         }},
        {"expect_exists",
         [&]() -> std::optional<bool> {
           if (!fs::exists(a["expect_exists"].get<std::string>()))
             return fail(a["expect_exists"].get<std::string>() + " does not exist");
           return std::nullopt;
         }},
        {"open_compressed",
         [&]() -> std::optional<bool> {
           if (a.contains("gpu_table_mib")) {
             const json& m = a["gpu_table_mib"];
             if (!m.is_number() || !(m.get<double>() >= 1 && m.get<double>() <= 4096))
               return fail("open_compressed: gpu_table_mib must be a number in [1, 4096], got " +
                           m.dump());
             obj.gpuTableFloats = uint64_t(m.get<double>() * double(1 << 20) / 4);
             obj.bound.clear();  // the tables are made again when the file is bound
           }
           openCompressed(a["open_compressed"], str("reference"));
           return std::nullopt;
         }},
        {"compare",
         [&]() -> std::optional<bool> {
           compareInspector();
           waitFor([this] { return !jobs.busy() && insp.haveReport; }, a.value("wait", 120.0),
                   "the comparison");
           return std::nullopt;
         }},
        {"codec_options",
         [&]() -> std::optional<bool> {
           // What the Jobs form's codec options would hold: {"neural_steps": 300, …}.
           for (const auto& [k, v] : a["codec_options"].items()) {
             if (!form.codecOptions.decl().find(k))
               return fail("codec_options: '" + k + "' is not an option of compress");
             try {
               if (v.is_boolean())
                 form.codecOptions.setFlag(k, v.get<bool>());
               else
                 form.codecOptions.set(k, v.is_string() ? v.get<std::string>() : v.dump());
             } catch (const std::exception& e) {
               return fail(std::string("codec_options: ") + e.what());
             }
           }
           return std::nullopt;
         }},
        {"codec_sweep",
         [&]() -> std::optional<bool> {
           m_lastJobId = startCodecSweep(a["codec_sweep"].get<std::string>());
           if (a.value("wait", 0.0) > 0)
             waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(),
                     "the codec sweep", true);
           return std::nullopt;
         }},
        {"expect_codec_rows",
         [&]() -> std::optional<bool> {
           if (int(insp.codecs.size()) != a["expect_codec_rows"].get<int>())
             return fail("the inspector has " + std::to_string(insp.codecs.size()) + " codec rows");
           for (const auto& r : insp.codecs)
             if (!(r.ratio > 1) || !(r.relRmse >= 0) || !std::isfinite(r.psnr))
               return fail("codec row " + r.codec + " has invalid metrics");
           return std::nullopt;
         }},
        {"load_study",
         [&]() -> std::optional<bool> {
           loadStudy(a["load_study"]);
           return std::nullopt;
         }},
        {"panel",
         [&]() -> std::optional<bool> {
           const std::string p = a["panel"];
           if (!panels.count(p)) return fail("unknown panel '" + p + "'");
           panels[p] = true;
           focusPanel = p;
           m_scriptWaitFrames = a.value("frames", 3);
           return std::nullopt;
         }},
        {"drop",
         [&]() -> std::optional<bool> {
           for (const auto& p : a["drop"]) m_dropped.push_back(p.get<std::string>());
           m_scriptWaitFrames = 2;
           return std::nullopt;
         }},
        {"expect_parts",
         [&]() -> std::optional<bool> {
           if (int(doc.scene().parts.size()) != a["expect_parts"].get<int>())
             return fail("the scene has " + std::to_string(doc.scene().parts.size()) +
                         " parts, expected " + a["expect_parts"].dump());
           return std::nullopt;
         }},
        {"layout",
         [&]() -> std::optional<bool> {
           for (auto& [name, open] : panels) open = false;
           for (const auto& n : a["layout"]) {
             if (!panels.count(n.get<std::string>())) return fail("unknown panel " + n.dump());
             panels[n.get<std::string>()] = true;
           }
           m_scriptWaitFrames = 3;
           return std::nullopt;
         }},
        {"object",
         [&]() -> std::optional<bool> {
           for (const char* k :
                {"yaw", "pitch", "light_theta", "light_phi", "relief_scale", "tiling",
                 "render_scale"})
             if (a.contains(k) && !a[k].is_number())
               return fail(std::string("object: ") + k + " must be a number");
           if (a.contains("render_scale")) {
             // The panel's own slider: pixels of the pass per pixel of the panel.
             const double rs = a["render_scale"];
             if (!(rs >= 0.25 && rs <= 1))
               return fail("object: render_scale must be in [0.25, 1] (the panel's slider), got " +
                           a["render_scale"].dump());
             obj.renderScale = float(rs);
           }
           obj.shape = a["object"];
           // Nobody interacts while a script waits for the pass: bands of 250 ms (the same
           // pixels in fewer frames); "wait": 0 measures the interactive bands of 10 ms.
           obj.bandMs = a.contains("wait") && a["wait"] == 0 ? 10 : 250;
           // Texel levels of a pyramid file (docs/mip.md): on/off, false colour, tiling.
           obj.mip = a.value("mip", obj.mip);
           obj.showLevel = a.value("show_level", obj.showLevel);
           obj.tiling = a.value("tiling", obj.tiling);
           // The GPU view (flat or mapped: the shell march) and the relief scale.
           if (a.contains("view")) {
             const std::string v = a["view"];
             if (v != "flat" && v != "mapped")
               return fail("object: view must be \"flat\" or \"mapped\", got \"" + v + "\"");
             obj.view = v == "mapped" ? 1 : 0;
           }
           obj.reliefScale = a.value("relief_scale", obj.reliefScale);
           obj.yaw = a.value("yaw", obj.yaw);
           obj.pitch = a.value("pitch", obj.pitch);
           obj.lightTheta = a.value("light_theta", obj.lightTheta);
           obj.lightPhi = a.value("light_phi", obj.lightPhi);
           m_scriptWaitFrames = 2;
           // Then wait for the banded pass to complete (the panel must be open), unless
           // "wait": 0 (frames measured while it runs).
           if (a.contains("wait") && a["wait"] == 0) return std::nullopt;
           m_waitFor = [this] {
             // A mapped view that cannot be drawn shows its message instead: nothing to wait for.
             return !panels["Objects"] || (obj.view == 1 && !obj.shellError.empty()) ||
                    (obj.band < 0 && !obj.renderedKey.empty() && obj.loadedShape == obj.shape);
           };
           m_waitDeadline = Clock::now() + std::chrono::seconds(300);
           m_waitWhat = "the object pass";
           return std::nullopt;
         }},
        {"frames",
         [&]() -> std::optional<bool> {
           m_scriptWaitFrames = a["frames"];
           return std::nullopt;
         }},
        {"interactive",
         [&]() -> std::optional<bool> {
           // The pacing of a user's session (waits for events while nothing runs) for that many
           // seconds; the report's frames_drawn shows it.
           const json& v = a["interactive"];
           if (!v.is_number() || !(v.get<double>() > 0 && v.get<double>() <= 600))
             return fail("interactive: expected seconds in (0, 600], got " + v.dump());
           m_interactiveUntil = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                   std::chrono::duration<double>(v.get<double>()));
           m_waitUntil = m_interactiveUntil;
           m_settleFrames = 0;
           m_report["interactive_from_frame"] = m_frames;
           return std::nullopt;
         }},
        {"sleep",
         [&]() -> std::optional<bool> {
           m_waitUntil =
               Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(a["sleep"].get<double>()));
           return std::nullopt;
         }},
        {"screenshot",
         [&]() -> std::optional<bool> {
           m_screenshotPending = a["screenshot"];
           m_scriptWaitFrames = 1;
           return std::nullopt;
         }},
        {"check_glsl",
         [&]() -> std::optional<bool> {
           const json& c = a["check_glsl"];
           json result;
           const bool ok = checkGlsl(objectView(), c.value("samples", 256),
                                     c.value("tolerance", 0.02), &result);
           m_report["check_glsl"] = result;
           m_report["check_glsl_" + objectView().insp.cbtf->codec +
                    (objectView().insp.cbtf->levels.empty() ? "" : "_mip")] = result;
           if (c.contains("name")) m_report["check_glsl_" + c["name"].get<std::string>()] = result;
           if (!ok) return fail("GLSL decoder differs from the CPU decoder: " + result.dump());
           return std::nullopt;
         }},
        {"check_mapped",
         [&]() -> std::optional<bool> {
           const json& c = a["check_mapped"];
           const json size = c.value("size", json::array({64, 48}));
           if (!size.is_array() || size.size() != 2 || !size[0].is_number_integer() ||
               !size[1].is_number_integer() || size[0] < 1 || size[1] < 1 || size[0] > 2048 ||
               size[1] > 2048)
             return fail("check_mapped: size must be [width, height], 1..2048 pixels each, got " +
                         size.dump());
           json result;
           const bool ok =
               checkMapped(objectView(), size.at(0).get<int>(), size.at(1).get<int>(),
                           c.value("max_differing", 0.005), c.value("max_mismatch", 0.01), &result);
           m_report["check_mapped"] = result;
           m_report["check_mapped_" + obj.shape] = result;
           if (!ok)
             return fail("the GLSL mapped view differs from the CPU renderer: " + result.dump());
           return std::nullopt;
         }},
        {"measure_frames",
         [&]() -> std::optional<bool> {
           const double secs = a["measure_frames"].get<double>();
           frameHistory.clear();
           const auto t0 = Clock::now();
           waitFor(
               [this, t0, secs] {
                 if (std::chrono::duration<double>(Clock::now() - t0).count() < secs) return false;
                 std::vector<double> v(frameHistory.begin(), frameHistory.end());
                 std::sort(v.begin(), v.end());
                 m_report["frames"] = {{"count", v.size()},
                                       {"median_ms", v.empty() ? 0 : v[v.size() / 2]},
                                       {"p95_ms", v.empty() ? 0 : v[v.size() * 95 / 100]},
                                       {"max_ms", v.empty() ? 0 : v.back()},
                                       {"job_running", jobs.busy()}};
                 return true;
               },
               secs + 30, "frame measurements");
           return std::nullopt;
         }},
        {"save",
         [&]() -> std::optional<bool> {
           saveScene(a["save"]);
           return std::nullopt;
         }},
        {"report",
         [&]() -> std::optional<bool> {
           m_report["_path"] = a["report"];
           return std::nullopt;
         }},
    };
    for (const auto& [name, handler] : handlers)
      if (a.contains(name)) {
        if (const auto r = handler()) return *r;
        handled = true;
        break;
      }
    if (!handled) return fail("unknown action " + a.dump());
  } catch (const std::exception& e) {
    return fail(e.what());
  }
  return true;
}

}  // namespace btf::ui
