// Background jobs: the estimate before starting, then per job its stage, progress bar, ETA,
// memory and cancel ("stop" keeps a simulation's partial file so it resumes next time).
#include <btf/core/sysinfo.h>
#include <btf/ops/ops.h>
#include <btf/sim/simulator.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include <filesystem>
#include <set>

#include "panels.h"

namespace btf::ui {

namespace fs = std::filesystem;

void drawJobsPanel(const JobsView& app) {
  if (!ImGui::Begin("Jobs", &app.open)) {
    ImGui::End();
    return;
  }
  JobForm& f = app.form;
  ImGui::SetNextItemWidth(200);
  ImGui::InputText("output (no extension)", &f.output);
  // Texels, directions and spp start from the scene's simulation block: a value typed here
  // overrides it for the jobs (the engine validates it, naming the option and its range);
  // "scene" goes back to the scene's value.
  const SimOptions fo = ops::simOptions(app.doc.scene(), f.sim);
  auto simField = [&](const char* label, const char* key, std::string shown, float width) {
    ImGui::SetNextItemWidth(width);
    std::string text = shown;
    if (ImGui::InputText(label, &text, ImGuiInputTextFlags_EnterReturnsTrue)) {
      try {
        f.sim.set(key, text);
      } catch (const std::exception& e) {
        app.act.message(e.what(), true);
      }
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("%s", f.sim.given(key) ? "set for the jobs" : "the scene's value");
    if (f.sim.given(key)) {
      ImGui::SameLine();
      std::string id = "scene##";  // (not literal + key: GCC 12's -Wrestrict false positive)
      id += key;
      if (ImGui::SmallButton(id.c_str())) f.sim.unset(key);
    }
    ImGui::SameLine();
  };
  std::string texels = std::to_string(fo.nu);
  if (fo.nv != fo.nu) texels += 'x' + std::to_string(fo.nv);
  simField("texels", "texels", texels, 70);
  simField("directions", "dirs", fo.directions, 80);
  simField("spp", "spp", std::to_string(fo.spp), 40);
  ImGui::NewLine();
  ImGui::SetNextItemWidth(90);
  if (ImGui::BeginCombo("codec", f.codec.c_str())) {
    for (const std::string& c : codecNames())
      if (ImGui::Selectable(c.c_str(), f.codec == c)) f.codec = c;
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90);
  ImGui::InputDouble("target ratio", &f.targetRatio, 10, 100, "%.0f");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(70);
  ImGui::InputInt("threads", &f.threads);
  f.threads = std::clamp(f.threads, 0, 256);
  // Every other declared option of the jobs' requests, through the declaration widgets.
  static std::string optionError;
  const std::set<std::string> shownAbove = {"scene",    "output", "texels",  "dirs",  "spp",
                                            "compress", "resume", "threads", "quiet", "json"};
  if (ImGui::TreeNode("simulation options")) {
    for (const auto& d : f.sim.decl().options)
      if (!shownAbove.count(d.name) &&
          (!f.codecOptions.decl().find(d.name) || d.name == "memory_budget")) {
        ImGui::SetNextItemWidth(120);
        requestParam(f.sim, d, &optionError);
      }
    ImGui::TreePop();
  }
  if (ImGui::TreeNode("codec options")) {
    for (const auto& d : f.codecOptions.decl().options)
      if (!shownAbove.count(d.name) && d.name != "input" && d.name != "codec" &&
          d.name != "target_ratio" && d.name != "compare") {
        ImGui::SetNextItemWidth(120);
        requestParam(f.codecOptions, d, &optionError);
      }
    ImGui::TreePop();
  }
  if (!optionError.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", optionError.c_str());
  const std::string btf = f.output + ".btf", cbtf = f.output + ".cbtf";
  const bool partial = fs::exists(btf + ".partial");
  ImGui::TextDisabled("%s", app.act.simulationEstimate().c_str());
  auto guarded = [&](const std::function<void()>& fn) {
    try {
      fn();
    } catch (const std::exception& e) {
      app.act.message(e.what(), true);
    }
  };
  if (ImGui::Button(partial && f.resume ? "Resume simulation" : "Simulate"))
    guarded([&] { app.act.startSimulation(btf, false); });
  ImGui::SameLine();
  if (ImGui::Button("Simulate + compress")) guarded([&] { app.act.startSimulation(btf, true); });
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("simulate to .btf, then compress it (the inspector can compare both)");
  ImGui::SameLine();
  if (ImGui::Button("Stream")) guarded([&] { app.act.startStreamedSimulation(cbtf); });
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("simulate straight into the codec: only the .cbtf is written");
  ImGui::SameLine();
  if (ImGui::Button("Compress")) guarded([&] { app.act.startCompression(btf, cbtf); });
  ImGui::SameLine();
  if (ImGui::Button("Study")) guarded([&] { app.act.startStudy(f.output + "-study"); });
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90);
  if (ImGui::BeginCombo("##fmt", f.exportFormat.c_str())) {
    for (const std::string& c : ops::command("export").find("format")->choices)
      if (ImGui::Selectable(c.c_str(), f.exportFormat == c)) f.exportFormat = c;
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  if (ImGui::Button("Export"))
    guarded([&] {
      const std::string out = f.exportFormat == "ubo2003"   ? f.output + "-ubo2003"
                              : f.exportFormat == "ubo2014" ? f.output + ".btf.dfmf"
                                                            : f.output + ".binary";
      app.act.startExport(fs::exists(cbtf) ? cbtf : btf, f.exportFormat, out);
    });
  if (partial) {
    ImGui::Checkbox("resume the interrupted run", &f.resume);
    ImGui::SameLine();
    ImGui::TextDisabled("(%s.partial exists)", btf.c_str());
  }
  ImGui::Separator();
  if (ImGui::SmallButton("clear finished")) app.jobs.clearFinished();
  for (const auto& j : app.jobs.jobs()) {
    ImGui::PushID(j->id);
    const JobStatus st = j->status.load();
    ImGui::Text("#%d %s", j->id, j->title.c_str());
    ImGui::SameLine();
    ImVec4 col = st == JobStatus::Failed      ? ImVec4(1, 0.4f, 0.3f, 1)
                 : st == JobStatus::Done      ? ImVec4(0.4f, 1, 0.5f, 1)
                 : st == JobStatus::Cancelled ? ImVec4(0.8f, 0.8f, 0.5f, 1)
                                              : ImVec4(0.7f, 0.8f, 1, 1);
    ImGui::TextColored(col, "[%s]", jobStatusName(st));
    if (st == JobStatus::Running || st == JobStatus::Queued) {
      const std::string stage = j->progress.currentStage();
      const double eta = j->etaSeconds();
      char overlay[160];
      std::snprintf(overlay, sizeof overlay, "%s %.0f %%%s%s", stage.c_str(), 100 * j->fraction(),
                    eta >= 0 ? " — ETA " : "", eta >= 0 ? formatSeconds(eta).c_str() : "");
      ImGui::ProgressBar(float(j->fraction()), ImVec2(-150, 0), overlay);
      ImGui::SameLine();
      if (ImGui::SmallButton("cancel")) app.jobs.cancel(j->id);
      if (j->kind == "simulate") {
        ImGui::SameLine();
        if (ImGui::SmallButton("stop")) {
          j->keepPartial = true;
          app.jobs.cancel(j->id);
        }
      }
      ImGui::TextDisabled("elapsed %s, process memory %s — %s",
                          formatSeconds(j->elapsedSeconds()).c_str(),
                          formatBytes(double(currentRssBytes())).c_str(), j->estimate.c_str());
    } else {
      ImGui::PushTextWrapPos(0);
      ImGui::TextDisabled("%s (%s, peak memory %s)", j->message.c_str(),
                          formatSeconds(j->elapsedSeconds()).c_str(),
                          formatBytes(double(j->peakRss.load())).c_str());
      ImGui::PopTextWrapPos();
    }
    ImGui::PopID();
  }
  ImGui::End();
}

}  // namespace btf::ui
