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

bool checkGlsl(App& app, int samples, double tolerance, json* result);  // object_viewer.cpp

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
  }
  if (m_scriptPos >= m_script.size()) {
    if (!m_report.empty() && m_report.contains("_path")) {
      std::ofstream f(m_report["_path"].get<std::string>());
      f << m_report.dump(2) << "\n";
    }
    return false;
  }
  const json& a = m_script[m_scriptPos];
  const std::string where = opt.script + ": action " + std::to_string(m_scriptPos + 1);
  ++m_scriptPos;
  auto fail = [&](const std::string& why) {
    message(where + ": " + why, true);
    m_exitStatus = 1;
    return false;
  };
  auto waitFor = [&](std::function<bool()> f, double seconds, const std::string& what) {
    m_waitFor = std::move(f);
    m_waitDeadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double>(seconds));
    m_waitWhat = what;
  };
  auto str = [&](const char* k, const std::string& def = "") {
    return a.contains(k) ? a[k].get<std::string>() : def;
  };
  try {
    if (!a.is_object()) return fail("expected an object like {\"open\": \"scene.json\"}");
    if (a.contains("open")) {
      openScene(a["open"].get<std::string>());
      m_originalJson = doc.json();
    } else if (a.contains("new")) {
      doc.reset(defaultScene(), {});
      m_originalJson = doc.json();
    } else if (a.contains("set")) {
      const std::string ptr = a["set"];
      if (a.contains("expect_error")) {
        const std::string before = doc.json();
        try {
          setParam(ptr, ordered(a.at("value")));
        } catch (const Error& e) {
          if (std::string(e.what()).find(a["expect_error"].get<std::string>()) == std::string::npos)
            return fail(std::string("error '") + e.what() + "' does not mention '" +
                        a["expect_error"].get<std::string>() + "'");
          if (doc.json() != before) return fail("a refused edit changed the scene");
          m_scriptWaitFrames = 1;
          return true;
        }
        return fail("setting " + ptr + " was expected to fail");
      }
      setParam(ptr, ordered(a.at("value")));
    } else if (a.contains("undo")) {
      for (int i = 0; i < a["undo"].get<int>(); ++i) undo();
    } else if (a.contains("redo")) {
      for (int i = 0; i < a["redo"].get<int>(); ++i) redo();
    } else if (a.contains("expect_original")) {
      if (doc.json() != m_originalJson)
        return fail("the scene differs from the one opened (undo did not restore it)");
    } else if (a.contains("random_edits")) {
      const json& r = a["random_edits"];
      std::mt19937_64 rng(r.value("seed", 1));
      const std::string start = doc.json();
      int made = 0;
      for (int i = 0; i < r.value("count", 100); ++i) made += randomEdit(doc, rng);
      const std::string end = doc.json();
      const size_t depth = doc.undoDepth();
      for (size_t i = 0; i < depth; ++i) doc.undo();
      if (doc.json() != start) return fail("undoing every random edit did not restore the scene");
      for (size_t i = 0; i < depth; ++i) doc.redo();
      if (doc.json() != end) return fail("redoing every random edit did not give the same scene");
      for (size_t i = 0; i < depth; ++i) doc.undo();  // leave the scene as it was
      m_report["random_edits"] = {{"made", made}, {"undo_depth", depth}};
    } else if (a.contains("directions")) {
      const json& d = a["directions"];
      if (d.contains("view")) pv.thetaV = d["view"][0], pv.phiV = d["view"][1];
      if (d.contains("light")) pv.thetaL = d["light"][0], pv.phiL = d["light"][1];
      if (d.contains("size")) pv.size = d["size"];
      requestPreview();
    } else if (a.contains("texel")) {
      pv.texelU = a["texel"][0];
      pv.texelV = a["texel"][1];
      requestPreview();
    } else if (a.contains("wait_preview")) {
      waitFor(
          [this] {
            if (pv.dirty || pv.result.generation != pv.generation || !pv.result.done) return false;
            m_report["preview_first_image_ms"].push_back(pv.firstImageSeconds * 1e3);
            m_report["preview_all_stages_ms"].push_back(pv.result.imageSeconds * 1e3);
            return true;
          },
          a["wait_preview"].get<double>(), "the preview");
    } else if (a.contains("save_preview")) {
      const auto& r = pv.result;
      if (r.image.empty()) return fail("no preview image yet");
      writeRgbImage(a["save_preview"], r.nu, r.nv, r.image, 1.0f);
      m_report["preview"] = {
          {"stage", r.stage}, {"size", r.nu}, {"first_image_ms", pv.firstImageSeconds * 1e3}};
    } else if (a.contains("save_brdf")) {
      const auto& r = pv.result;
      if (r.brdfValues.empty()) return fail("no BRDF slice yet");
      json pairs = json::array(), vals = json::array();
      for (size_t k = 0; k < r.brdfPairs.size(); ++k) {
        pairs.push_back(r.brdfPairs[k]);
        vals.push_back({r.brdfValues[k].x, r.brdfValues[k].y, r.brdfValues[k].z});
      }
      std::ofstream f(a["save_brdf"].get<std::string>());
      f << json{{"samples", r.brdfSamples}, {"pairs", pairs}, {"values", vals}}.dump() << "\n";
    } else if (a.contains("simulate")) {
      const json& s = a["simulate"];
      form.texels = s.value("texels", form.texels);
      form.directions = s.value("directions", form.directions);
      form.spp = s.value("spp", form.spp);
      form.codec = s.value("codec", form.codec);
      form.resume = s.value("resume", true);
      m_lastJobId = s.value("stream", false)
                        ? startStreamedSimulation(s.at("output"))
                        : startSimulation(s.at("output"), s.value("compress", false));
      if (a.value("wait", 0.0) > 0)
        waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(), "the simulation");
    } else if (a.contains("compress")) {
      const json& s = a["compress"];
      form.codec = s.value("codec", form.codec);
      form.targetRatio = s.value("target_ratio", form.targetRatio);
      m_lastJobId = startCompression(s.at("input"), s.at("output"));
      if (a.value("wait", 0.0) > 0)
        waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(), "the compression");
    } else if (a.contains("study")) {
      m_lastJobId = startStudy(a["study"].at("dir"));
      if (a.value("wait", 0.0) > 0)
        waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(), "the study");
    } else if (a.contains("export")) {
      const json& s = a["export"];
      m_lastJobId = startExport(s.at("input"), s.at("format"), s.at("output"));
      if (a.value("wait", 0.0) > 0)
        waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(), "the export");
    } else if (a.contains("cancel")) {
      auto j = jobs.find(m_lastJobId);
      if (!j) return fail("no job to cancel");
      const auto t0 = Clock::now();
      jobs.cancel(m_lastJobId);
      waitFor(
          [this, j, t0] {
            const JobStatus st = j->status.load();
            if (st == JobStatus::Queued || st == JobStatus::Running) return false;
            m_report["cancel_seconds"] = std::chrono::duration<double>(Clock::now() - t0).count();
            return true;
          },
          a.value("within", 1.0) + 0.25, "the cancelled job to stop");
    } else if (a.contains("wait_jobs")) {
      waitFor([this] { return !jobs.busy(); }, a["wait_jobs"].get<double>(), "the jobs");
    } else if (a.contains("expect_job")) {
      auto j = jobs.find(m_lastJobId);
      if (!j) return fail("no job");
      const json& e = a["expect_job"];
      const std::string st = jobStatusName(j->status.load());
      if (e.contains("status") && e["status"] != st)
        return fail("job " + j->title + " is " + st + ", expected " +
                    e["status"].get<std::string>() + " (" + j->message + ")");
      if (e.contains("message") &&
          j->message.find(e["message"].get<std::string>()) == std::string::npos)
        return fail("job message '" + j->message + "' lacks '" + e["message"].get<std::string>() +
                    "'");
    } else if (a.contains("expect_missing")) {
      if (fs::exists(a["expect_missing"].get<std::string>()))
        return fail(a["expect_missing"].get<std::string>() + " exists");
    } else if (a.contains("expect_exists")) {
      if (!fs::exists(a["expect_exists"].get<std::string>()))
        return fail(a["expect_exists"].get<std::string>() + " does not exist");
    } else if (a.contains("open_compressed")) {
      openCompressed(a["open_compressed"], str("reference"));
    } else if (a.contains("compare")) {
      compareInspector();
      waitFor([this] { return !jobs.busy() && insp.haveReport; }, a.value("wait", 120.0),
              "the comparison");
    } else if (a.contains("codec_sweep")) {
      m_lastJobId = startCodecSweep(a["codec_sweep"].get<std::string>());
      if (a.value("wait", 0.0) > 0)
        waitFor([this] { return !jobs.busy(); }, a["wait"].get<double>(), "the codec sweep");
    } else if (a.contains("expect_codec_rows")) {
      if (int(insp.codecs.size()) != a["expect_codec_rows"].get<int>())
        return fail("the inspector has " + std::to_string(insp.codecs.size()) + " codec rows");
      for (const auto& r : insp.codecs)
        if (!(r.ratio > 1) || !(r.relRmse >= 0) || !std::isfinite(r.psnr))
          return fail("codec row " + r.codec + " has invalid metrics");
    } else if (a.contains("load_study")) {
      loadStudy(a["load_study"]);
    } else if (a.contains("panel")) {
      const std::string p = a["panel"];
      if (!panels.count(p)) return fail("unknown panel '" + p + "'");
      panels[p] = true;
      focusPanel = p;
      m_scriptWaitFrames = a.value("frames", 3);
    } else if (a.contains("drop")) {
      for (const auto& p : a["drop"]) m_dropped.push_back(p.get<std::string>());
      m_scriptWaitFrames = 2;
    } else if (a.contains("expect_parts")) {
      if (int(doc.scene().parts.size()) != a["expect_parts"].get<int>())
        return fail("the scene has " + std::to_string(doc.scene().parts.size()) +
                    " parts, expected " + a["expect_parts"].dump());
    } else if (a.contains("layout")) {
      for (auto& [name, open] : panels) open = false;
      for (const auto& n : a["layout"]) {
        if (!panels.count(n.get<std::string>())) return fail("unknown panel " + n.dump());
        panels[n.get<std::string>()] = true;
      }
      m_scriptWaitFrames = 3;
    } else if (a.contains("object")) {
      obj.shape = a["object"];
      m_scriptWaitFrames = 2;
      // Then wait for the banded pass to complete (the panel must be open).
      m_waitFor = [this] {
        return !panels["Objects"] ||
               (obj.band < 0 && !obj.renderedKey.empty() && obj.loadedShape == obj.shape);
      };
      m_waitDeadline = Clock::now() + std::chrono::seconds(300);
      m_waitWhat = "the object pass";
    } else if (a.contains("frames")) {
      m_scriptWaitFrames = a["frames"];
    } else if (a.contains("sleep")) {
      m_waitUntil = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                       std::chrono::duration<double>(a["sleep"].get<double>()));
    } else if (a.contains("screenshot")) {
      m_screenshotPending = a["screenshot"];
      m_scriptWaitFrames = 1;
    } else if (a.contains("check_glsl")) {
      const json& c = a["check_glsl"];
      json result;
      const bool ok =
          checkGlsl(*this, c.value("samples", 256), c.value("tolerance", 0.02), &result);
      m_report["check_glsl"] = result;
      if (!ok) return fail("GLSL decoder differs from the CPU decoder: " + result.dump());
    } else if (a.contains("measure_frames")) {
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
    } else if (a.contains("save")) {
      saveScene(a["save"]);
    } else if (a.contains("report")) {
      m_report["_path"] = a["report"];
    } else {
      return fail("unknown action " + a.dump());
    }
  } catch (const std::exception& e) {
    return fail(e.what());
  }
  return true;
}

}  // namespace btf::ui
