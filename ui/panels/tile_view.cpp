// The 3D view of the tile: the micro-geometry rasterised in OpenGL, repeated 3 × 3 with the
// central tile outlined and the preview's light direction drawn as a line from the tile centre;
// orbit camera (drag, wheel); a click picks the part under the cursor (colour-coded ids).
#include <btf/geometry/tile_builder.h>
#include <btf/scene/material.h>
#include <imgui.h>

#include <cstdio>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "panels.h"

namespace btf::ui {

namespace {

void rebuild(const TileViewView& app) {
  TileViewState& t = app.tile;
  t.builtRevision = app.doc.revision();
  t.error.clear();
  TileGeometry g;
  try {
    g = buildTileGeometry(app.doc.scene());
  } catch (const std::exception& e) {
    t.error = e.what();  // the last good mesh stays on screen
    return;
  }
  std::vector<gl::Vertex> v;
  std::vector<uint32_t> idx;
  v.reserve(g.mesh.tri.size() * 3);
  for (size_t k = 0; k < g.mesh.tri.size(); ++k) {
    const Vec3 n = glm::normalize(g.faceNormal(uint32_t(k)));
    for (int c = 0; c < 3; ++c) {
      const Vec3 p = g.mesh.pos[g.mesh.tri[k][c]];
      gl::Vertex x{{p.x, p.y, p.z}, {n.x, n.y, n.z}, {float(g.triPart[k]), 0}};
      if (!std::isfinite(x.n[0])) x.n[0] = x.n[1] = 0, x.n[2] = 1;
      idx.push_back(uint32_t(v.size()));
      v.push_back(x);
    }
  }
  t.mesh.set(v, idx);
  t.Lx = float(g.Lx), t.Ly = float(g.Ly), t.zmin = g.zmin, t.zmax = g.zmax;
  // Part colours: the diffuse colour of each part's material.
  const Scene& s = app.doc.scene();
  const auto mats = compileMaterials(s);
  t.partColours.clear();
  for (const auto& p : s.parts) {
    const int m = s.materialIndex(p.material);
    Rgb c = m >= 0 ? mats[size_t(m)].kdOverPi * float(kPi) : Rgb(0.7f);
    if (c.x + c.y + c.z < 0.05f) c = Rgb(0.5f);
    t.partColours.push_back({c.x, c.y, c.z});
  }
  // Outline of the central tile and the light direction.
  const float z = g.zmax + 0.002f;
  std::vector<gl::Vertex> o = {{{0, 0, z}, {}, {}},
                               {{t.Lx, 0, z}, {}, {}},
                               {{t.Lx, t.Ly, z}, {}, {}},
                               {{0, t.Ly, z}, {}, {}}};
  t.outline.set(o, {0, 1, 1, 2, 2, 3, 3, 0}, true);
}

}  // namespace

void drawTileView(const TileViewView& app) {
  TileViewState& t = app.tile;
  if (!ImGui::Begin("Tile view", &app.open)) {
    ImGui::End();
    return;
  }
  try {
    if (!t.program.valid()) {
      t.program.build("tile", shaderSource("tile.vert"), shaderSource("tile.frag"));
      t.lines.build("lines", shaderSource("lines.vert"), shaderSource("lines.frag"));
    }
  } catch (const std::exception& e) {
    t.error = e.what();
  }
  if (t.builtRevision != app.doc.revision()) rebuild(app);
  if (!t.error.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", t.error.c_str());
  if (!t.program.valid()) {
    ImGui::End();
    return;
  }
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const int w = std::max(64, int(avail.x)), h = std::max(64, int(avail.y - 4));
  t.fb.resize(w, h, false);
  const float L = std::max(t.Lx, t.Ly);
  const glm::vec3 centre(t.Lx / 2, t.Ly / 2, (t.zmin + t.zmax) / 2);
  const float d = t.distance * L;
  const glm::vec3 eye =
      centre + glm::vec3(d * std::cos(t.pitch) * std::cos(t.yaw),
                         d * std::cos(t.pitch) * std::sin(t.yaw), d * std::sin(t.pitch));
  const glm::mat4 vp =
      glm::perspective(glm::radians(40.0f), float(w) / float(h), 0.01f * L, 50 * L) *
      glm::lookAt(eye, centre, glm::vec3(0, 0, 1));
  const double tl = deg2rad(app.pv.thetaL), pl = deg2rad(app.pv.phiL);
  const glm::vec3 ldir(float(std::sin(tl) * std::cos(pl)), float(std::sin(tl) * std::sin(pl)),
                       float(std::cos(tl)));
  auto drawScene = [&](bool pick) {
    t.program.use();
    t.program.setMat4("u_viewProj", glm::value_ptr(vp));
    t.program.set("u_tileSize", t.Lx, t.Ly);
    t.program.set("u_repeat", 3);
    t.program.set("u_lightDir", ldir.x, ldir.y, ldir.z);
    t.program.set("u_selected", t.selectedPart);
    t.program.set("u_pick", pick ? 1 : 0);
    std::vector<float> cols(48, 0.7f);
    for (size_t i = 0; i < t.partColours.size() && i < 16; ++i)
      for (int c = 0; c < 3; ++c) cols[i * 3 + size_t(c)] = t.partColours[i][size_t(c)];
    t.program.setVec3s("u_colours", cols.data(), 16);
    t.mesh.drawInstanced(9);
  };
  // Drawn only when something it shows changed (nine copies of a fine mesh are a large part of
  // an idle frame under llvmpipe); the framebuffer keeps the last image.
  char key[256];
  std::snprintf(key, sizeof key, "%llu|%d|%d|%.5f|%.5f|%.5f|%.5f|%.5f|%d",
                static_cast<unsigned long long>(t.builtRevision), w, h, t.yaw, t.pitch, t.distance,
                app.pv.thetaL, app.pv.phiL, t.selectedPart);
  if (key != t.drawnKey) {
    t.drawnKey = key;
    ++t.draws;
    t.fb.begin(0.12f, 0.12f, 0.15f, 1);
    gl::begin3d();
    drawScene(false);
    t.lines.use();
    t.lines.setMat4("u_viewProj", glm::value_ptr(vp));
    t.lines.set("u_colour", 1.0f, 1.0f, 1.0f);
    t.outline.draw();
    const glm::vec3 a(t.Lx / 2, t.Ly / 2, t.zmax), b = a + ldir * (0.6f * L);
    t.lightLine.set({{{a.x, a.y, a.z}, {}, {}}, {{b.x, b.y, b.z}, {}, {}}}, {0, 1}, true);
    t.lines.set("u_colour", 1.0f, 0.85f, 0.2f);
    t.lightLine.draw();
    gl::end3d();
    gl::Framebuffer::end(app.width, app.height);
  }
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  ImGui::Image(t.fb.imguiId(), ImVec2(float(w), float(h)), ImVec2(0, 1), ImVec2(1, 0));
  if (ImGui::IsItemActive() && ImGui::IsMouseDragging(0, 2)) {
    const ImVec2 dm = ImGui::GetIO().MouseDelta;
    t.yaw -= dm.x * 0.01f;
    t.pitch = std::clamp(t.pitch + dm.y * 0.01f, 0.05f, 1.55f);
  } else if (ImGui::IsItemHovered() && ImGui::IsMouseReleased(0) &&
             ImGui::GetMouseDragDelta(0).x == 0 && ImGui::GetMouseDragDelta(0).y == 0) {
    // Pick: render part ids and read the pixel under the cursor.
    t.pick.resize(w, h, false);
    t.pick.begin(0, 0, 0, 1);
    gl::begin3d();
    drawScene(true);
    gl::end3d();
    const ImVec2 m = ImGui::GetIO().MousePos;
    const int px = int(m.x - p0.x), py = h - 1 - int(m.y - p0.y);
    const auto rgba = t.pick.readPixel(px, py);
    gl::Framebuffer::end(app.width, app.height);
    const int id = int(rgba[0]) + 256 * int(rgba[1]);
    t.selectedPart = id - 1;
    if (id > 0 && id - 1 < int(app.doc.scene().parts.size()))
      app.act.message("selected part '" + app.doc.scene().parts[size_t(id - 1)].name + "'");
  }
  if (ImGui::IsItemHovered() && ImGui::GetIO().MouseWheel != 0)
    t.distance = std::clamp(t.distance * std::pow(0.9f, ImGui::GetIO().MouseWheel), 0.5f, 20.0f);
  ImGui::End();
}

}  // namespace btf::ui
