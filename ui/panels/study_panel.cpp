// Accuracy versus time for the current scene: the study's configurations as points (wall time
// vs relative error, log-log), the Pareto front joined, the settings the Jobs form would use
// marked; hover for the configuration.
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cmath>

#include "panels.h"
#include "widgets.h"

namespace btf::ui {

void drawStudyPanel(const StudyView& app) {
  StudyState& s = app.study;
  if (!ImGui::Begin("Study", &app.open)) {
    ImGui::End();
    return;
  }
  static std::string dir = "out/studio-study";
  ImGui::SetNextItemWidth(220);
  ImGui::InputText("study folder", &dir);
  ImGui::SameLine();
  if (ImGui::Button("Load")) {
    try {
      app.act.loadStudy(dir);
    } catch (const std::exception& e) {
      app.act.message(e.what(), true);
    }
  }
  ImGui::SameLine();
  if (ImGui::Button("Run study")) app.act.startStudy(dir);
  if (!s.error.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", s.error.c_str());
  if (s.points.empty()) {
    ImGui::TextDisabled("No study loaded: run one (Jobs → Study) or load a folder with study.csv.");
    ImGui::End();
    return;
  }
  ImGui::Text("%s: %zu configurations; chosen: %s", s.dir.c_str(), s.points.size(),
              s.chosen.empty() ? "(none matches the Jobs form)" : s.chosen.c_str());
  double t0 = 1e30, t1 = 0, e0 = 1e30, e1 = 0;
  for (const auto& p : s.points) {
    if (p.seconds > 0) t0 = std::min(t0, p.seconds), t1 = std::max(t1, p.seconds);
    if (p.error > 0) e0 = std::min(e0, p.error), e1 = std::max(e1, p.error);
  }
  t0 /= 1.3, t1 *= 1.3, e0 /= 1.3, e1 *= 1.3;
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const ImVec2 size(ImGui::GetContentRegionAvail().x,
                    std::max(120.0f, ImGui::GetContentRegionAvail().y - 4));
  ImGui::InvisibleButton("##plot", size);
  dl->AddRectFilled(p, ImVec2(p.x + size.x, p.y + size.y), IM_COL32(30, 30, 36, 255));
  const float padL = 56, padB = 20;
  auto X = [&](double v) {
    return p.x + padL +
           float((std::log(std::max(v, t0)) - std::log(t0)) / (std::log(t1) - std::log(t0))) *
               (size.x - padL - 8);
  };
  auto Y = [&](double v) {
    return p.y + 6 +
           float(1 - (std::log(std::max(v, e0)) - std::log(e0)) / (std::log(e1) - std::log(e0))) *
               (size.y - padB - 12);
  };
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3g %%", 100 * e1);
  dl->AddText(ImVec2(p.x + 2, p.y + 2), IM_COL32(200, 200, 200, 255), buf);
  std::snprintf(buf, sizeof buf, "%.3g %%", 100 * e0);
  dl->AddText(ImVec2(p.x + 2, p.y + size.y - padB - 14), IM_COL32(200, 200, 200, 255), buf);
  std::snprintf(buf, sizeof buf, "%.3g s", t0);
  dl->AddText(ImVec2(p.x + padL, p.y + size.y - padB + 2), IM_COL32(200, 200, 200, 255), buf);
  std::snprintf(buf, sizeof buf, "%.3g s  (wall time, log)", t1);
  dl->AddText(ImVec2(p.x + size.x - 170, p.y + size.y - padB + 2), IM_COL32(200, 200, 200, 255),
              buf);
  std::vector<const StudyState::Point*> front;
  for (const auto& q : s.points)
    if (q.pareto) front.push_back(&q);
  std::sort(front.begin(), front.end(), [](auto* a, auto* b) { return a->seconds < b->seconds; });
  for (size_t i = 1; i < front.size(); ++i)
    dl->AddLine(ImVec2(X(front[i - 1]->seconds), Y(front[i - 1]->error)),
                ImVec2(X(front[i]->seconds), Y(front[i]->error)), IM_COL32(255, 200, 60, 200),
                1.5f);
  const ImVec2 m = ImGui::GetIO().MousePos;
  for (const auto& q : s.points) {
    const ImVec2 c(X(q.seconds), Y(q.error));
    dl->AddCircleFilled(c, q.pareto ? 5.0f : 3.5f,
                        q.pareto ? IM_COL32(255, 200, 60, 255) : IM_COL32(120, 170, 255, 255));
    if (q.label == s.chosen) dl->AddCircle(c, 9, IM_COL32(255, 80, 80, 255), 16, 2);
    if (ImGui::IsItemHovered() && std::abs(m.x - c.x) < 6 && std::abs(m.y - c.y) < 6)
      ImGui::SetTooltip("%s\n%.3g s, relative error %.2f %%%s", q.label.c_str(), q.seconds,
                        100 * q.error, q.pareto ? "\n(Pareto front)" : "");
  }
  ImGui::End();
}

}  // namespace btf::ui
