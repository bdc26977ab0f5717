// The object viewer: the compressed BTF mapped on objects and decoded on the GPU by the GLSL in
// shaders/ (btf_decode.glsl: texture-buffer arrays, direction interpolation, bilinear texels),
// with per-pixel tangent frames, light and orbit-camera control, exposure and tone mapping.
// checkGlsl() renders the same decoder into a float framebuffer for comparison with the CPU.
#include <btf/compress/mip.h>
#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/directions/direction_set.h>
#include <btf/io/image_io.h>
#include <imgui.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "../objects.h"
#include "panels.h"

namespace btf::ui {

using nlohmann::json;

namespace {

std::string decoderFragment(const std::string& body) {
  return "#version 330 core\n" + shaderSource("btf_decode.glsl") + "\n" + shaderSource(body);
}

// Uploads the compressed arrays as texture buffers and sets the decoder's uniforms; `levels`:
// a pyramid's texel levels too (docs/mip.md), else level 0 alone.
void bindDecoder(const ObjectView& app, const gl::Program& prog, bool levels) {
  ObjectState& o = app.obj;
  const CompressedBtf& c = *app.insp.cbtf;
  if (o.bound != app.insp.compressed) {
    o.buffers.clear();
    auto addData = [&](const float* data, size_t n, bool half) {
      auto b = std::make_unique<gl::TextureBuffer>();
      const float zero = 0;
      if (n > 0)
        b->set(data, n, half);
      else
        b->set(&zero, 1, false);
      o.buffers.push_back(std::move(b));
    };
    auto add = [&](const std::string& name) {
      if (c.hasArray(name)) {
        const CArray& a = c.array(name);
        addData(a.data.data(), a.data.size(), a.type == ArrayType::F16);
      } else {
        addData(nullptr, 0, false);
      }
    };
    // tensor: derived tables (offsets, per-texel matrices up to 64 MiB) beside the arrays.
    const TensorGpuTables tables =
        c.codec == "tensor" ? tensorGpuTables(c, uint64_t(16) << 20) : TensorGpuTables{};
    for (int ch = 0; ch < 3; ++ch) {
      if (c.codec == "nmf") {
        for (const char* w : {"basis_view", "basis_light", "coef_view", "coef_light"})
          add(channelArray(ch, w));
      } else if (c.codec == "tensor") {
        for (const char* w : {"view", "light", "core"}) add(channelArray(ch, w));
        addData(tables.clusters[ch].data(), tables.clusters[ch].size(), false);
      } else {
        add(channelArray(ch, "basis"));
        add(channelArray(ch, "coef"));
        add("none");
        add("none");
      }
    }
    if (c.codec == "tensor") {
      addData(tables.texels.data(), tables.texels.size(), false);
      add("coef");
      addData(tables.matrices.data(), tables.matrices.size(), false);
    } else {
      add("cluster");
      add("none");
      add("none");
    }
    o.bound = app.insp.compressed;
  }
  prog.use();
  const char* names[3][4] = {{"u_a0", "u_b0", "u_c0buf", "u_d0"},
                             {"u_a1", "u_b1", "u_c1buf", "u_d1"},
                             {"u_a2", "u_b2", "u_c2buf", "u_d2"}};
  for (int ch = 0; ch < 3; ++ch)
    for (int k = 0; k < 4; ++k)
      prog.bindBuffer(names[ch][k], *o.buffers[size_t(ch * 4 + k)], ch * 4 + k);
  prog.bindBuffer("u_cluster", *o.buffers[12], 12);
  // Units 14 and 15 (13 is the decoder check's queries).
  prog.bindBuffer("u_tcoef", *o.buffers[13], 14);
  prog.bindBuffer("u_tM", *o.buffers[14], 15);
  int c0[3] = {0, 0, 0}, c1[3] = {0, 0, 0}, k[3] = {0, 0, 0};
  for (int ch = 0; ch < 3; ++ch) {
    if (c.codec == "nmf") {
      c0[ch] = int(c.array(channelArray(ch, "basis_view")).cols);
      c1[ch] = int(c.array(channelArray(ch, "basis_light")).cols);
      k[ch] = c0[ch] > 0 ? int(c.array(channelArray(ch, "coef_view")).cols / c0[ch]) : 0;
    } else if (c.codec != "tensor") {
      c0[ch] = int(c.array(channelArray(ch, "basis")).cols);
    }
  }
  prog.setInts("u_c0", c0, 3);
  prog.setInts("u_c1", c1, 3);
  prog.setInts("u_k", k, 3);
  const int codec = c.codec == "nmf"       ? 0
                    : c.codec == "svd"     ? 1
                    : c.codec == "perview" ? 2
                    : c.codec == "lpca"    ? 3
                                           : 4;
  prog.set("u_codec", codec);
  prog.set("u_ycc", c.colour == "ycc" ? 1 : 0);
  prog.set("u_nu", c.info.nu);
  prog.set("u_nv", c.info.nv);
  prog.set("u_n", c.info.nDirs());
  const DirectionSet set = DirectionSet::fromName(c.info.directionSet);
  const auto& rings = set.rings();
  if (rings.size() > 48) throw Error("the GLSL decoder handles at most 48 rings");
  std::vector<float> th, ph;
  std::vector<int> cnt, first;
  for (const auto& r : rings) {
    th.push_back(float(r.theta));
    ph.push_back(float(r.phiOffset));
    cnt.push_back(r.count);
    first.push_back(r.first);
  }
  const int nLevels = levels ? int(c.levels.size()) : 0;
  if (nLevels > 16) throw Error("the GLSL decoder handles at most 16 texel levels");
  std::vector<int> lnu(16, 1), lnv(16, 1), lfirst(16, 0);
  for (int k = 0; k < nLevels; ++k)
    lnu[size_t(k)] = c.levels[size_t(k)].nu, lnv[size_t(k)] = c.levels[size_t(k)].nv,
    lfirst[size_t(k)] = int(c.levels[size_t(k)].first);
  prog.set("u_nLevels", std::max(1, nLevels));
  prog.setInts("u_levelNu", lnu.data(), 16);
  prog.setInts("u_levelNv", lnv.data(), 16);
  prog.setInts("u_levelFirst", lfirst.data(), 16);
  prog.set("u_nRings", int(rings.size()));
  prog.setFloats("u_ringTheta", th.data(), int(th.size()));
  prog.setFloats("u_ringPhi0", ph.data(), int(ph.size()));
  prog.setInts("u_ringCount", cnt.data(), int(cnt.size()));
  prog.setInts("u_ringFirst", first.data(), int(first.size()));
}

}  // namespace

bool checkGlsl(const ObjectView& app, int samples, double tolerance, json* result) {
  if (!app.insp.cbtf || !app.insp.decoder) throw Error("check_glsl: open a compressed BTF first");
  gl::Program prog;
  prog.build("btf_check", shaderSource("fullscreen.vert"), decoderFragment("btf_check.frag"));
  const CompressedBtf& cb = *app.insp.cbtf;
  const BtfInfo& I = cb.info;
  // A pyramid: the filtered decode over its levels (level selection, taps, trilinear) against
  // the CPU's evaluateFiltered, with footprints from under a texel to past the last level.
  const bool filtered = !cb.levels.empty();
  // The GPU's rule: one tap, the long axis sets the level (texelFilter's maxAniso 0).
  const int maxAniso = 0, m = filtered ? 10 : 6;
  std::vector<std::unique_ptr<Decoder>> owned;
  std::vector<const Decoder*> levels;
  if (filtered) {
    std::shared_ptr<const Decoder> all = makeDecoder(asStrip(cb));
    for (size_t k = 0; k < cb.levels.size(); ++k) {
      owned.push_back(pyramidLevel(all, cb.info, int(k)));
      levels.push_back(owned.back().get());
    }
  }
  // Queries: texel positions anywhere on the tile, directions up to 85°; a fixed seed.
  std::vector<float> q;
  Rng rng(12345);
  for (int k = 0; k < samples; ++k) {
    q.push_back(float(rng.uniform() * I.nu));
    q.push_back(float(rng.uniform() * I.nv));
    q.push_back(float(rng.uniform() * deg2rad(85.0)));
    q.push_back(float(rng.uniform() * 2 * kPi));
    q.push_back(float(rng.uniform() * deg2rad(85.0)));
    q.push_back(float(rng.uniform() * 2 * kPi));
    if (filtered) {
      // Axes of 0.3 to 2·(texels a side) texels, any orientation, up to 16:1 elongation: every
      // level, and blends between them.
      const double len = 0.3 * std::pow(2.0 * std::max(I.nu, I.nv) / 0.3, rng.uniform());
      const double ang = rng.uniform() * 2 * kPi, ratio = std::pow(16.0, rng.uniform());
      q.push_back(float(len * std::cos(ang)));
      q.push_back(float(len * std::sin(ang)));
      q.push_back(float(-len / ratio * std::sin(ang)));
      q.push_back(float(len / ratio * std::cos(ang)));
    }
  }
  gl::TextureBuffer qb;
  qb.set(q.data(), q.size(), false);
  const int W = 64, H = (samples + W - 1) / W;
  gl::Framebuffer fb;
  fb.resize(W, H, true);
  fb.begin(0, 0, 0, 0);
  bindDecoder(app, prog, filtered);
  prog.bindBuffer("u_queries", qb, 13);
  prog.set("u_width", W);
  prog.set("u_filtered", filtered ? 1 : 0);
  gl::drawFullscreen();
  const auto px = fb.readFloat();
  gl::Framebuffer::end(app.width, app.height);
  double maxAbs = 0, peak = 0, se = 0, ref2 = 0, lodDiff = 0;
  for (int k = 0; k < samples; ++k) {
    const float* s = &q[size_t(k) * size_t(m)];
    std::array<float, 3> cpu;
    if (filtered) {
      const double a[2] = {s[6], s[7]}, b[2] = {s[8], s[9]};
      double lod = 0;
      cpu = evaluateFiltered(levels, s[0], s[1], a, b, maxAniso, s[2], s[3], s[4], s[5], &lod);
      lodDiff = std::max(lodDiff, std::abs(double(px[size_t(k) * 4 + 3]) - lod));
    } else {
      cpu = app.insp.decoder->evaluateAt(s[0], s[1], s[2], s[3], s[4], s[5]);
    }
    for (int c = 0; c < 3; ++c) {
      const double g = px[size_t(k) * 4 + size_t(c)], r = cpu[size_t(c)];
      maxAbs = std::max(maxAbs, std::abs(g - r));
      peak = std::max(peak, std::abs(r));
      se += (g - r) * (g - r);
      ref2 += r * r;
    }
  }
  const double rel = peak > 0 ? maxAbs / peak : maxAbs;
  *result = {{"samples", samples},
             {"max_abs", maxAbs},
             {"peak", peak},
             {"max_rel_to_peak", rel},
             {"rel_rmse", ref2 > 0 ? std::sqrt(se / ref2) : 0},
             {"tolerance", tolerance},
             {"levels", filtered ? int(cb.levels.size()) : 1}};
  if (filtered) (*result)["max_lod_difference"] = lodDiff;
  return rel <= tolerance && lodDiff <= 1e-3;
}

void drawObjectViewer(const ObjectView& app) {
  ObjectState& o = app.obj;
  if (!ImGui::Begin("Objects", &app.open)) {
    ImGui::End();
    return;
  }
  ImGui::SetNextItemWidth(110);
  if (ImGui::BeginCombo("object", o.shape.c_str())) {
    for (const auto& n : objectNames())
      if (ImGui::Selectable(n.c_str(), n == o.shape)) o.shape = n;
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90);
  ImGui::SliderFloat("tiling", &o.tiling, 0.25f, 16, "%.2f", ImGuiSliderFlags_Logarithmic);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90);
  ImGui::SliderFloat("exposure", &o.exposure, 0.05f, 20, "%.2f", ImGuiSliderFlags_Logarithmic);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90);
  ImGui::Combo("tone map", &o.toneMap, "clamp\0Reinhard\0filmic\0");
  ImGui::SetNextItemWidth(120);
  ImGui::SliderFloat("light θ", &o.lightTheta, 0, 89);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(120);
  ImGui::SliderFloat("light φ", &o.lightPhi, -180, 180);
  ImGui::SameLine();
  ImGui::Checkbox("bilinear texels", &o.bilinear);
  if (app.insp.cbtf && !app.insp.cbtf->levels.empty()) {
    // A pyramid (compress --mip): the level per pixel from its footprint, or level 0.
    ImGui::SameLine();
    ImGui::Checkbox("texel levels", &o.mip);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "trilinear over the file's %zu texel levels, chosen per pixel from its "
          "footprint (docs/mip.md)",
          app.insp.cbtf->levels.size());
    ImGui::SameLine();
    ImGui::Checkbox("show level", &o.showLevel);
  }
  ImGui::SameLine();
  ImGui::SetNextItemWidth(80);
  ImGui::SliderFloat("render scale", &o.renderScale, 0.25f, 1.0f, "%.2f");
  // The CPU renderer on the same view (a job): mode, samples, relief scale.
  ImGui::SetNextItemWidth(80);
  ImGui::Combo("CPU mode", &o.cpuMode, "all\0exact\0mapped\0flat\0");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(80);
  ImGui::SliderInt("CPU spp", &o.cpuSpp, 1, 64, "%d", ImGuiSliderFlags_Logarithmic);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90);
  ImGui::SliderFloat("relief scale", &o.reliefScale, 0.25f, 4, "%.2f",
                     ImGuiSliderFlags_Logarithmic);
  ImGui::SameLine();
  if (ImGui::Button("Render on CPU")) {
    static const char* const kModes[] = {"all", "exact", "mapped", "flat"};
    try {
      app.act.startObjectRender(kModes[std::clamp(o.cpuMode, 0, 3)], o.cpuSpp, 256);
    } catch (const std::exception& e) {
      app.act.message(e.what(), true);
    }
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "btfsim render on this view: exact | mapped | flat | difference "
        "(docs/render.md)");
  if (!app.insp.cbtf) {
    ImGui::TextDisabled("Open a compressed BTF (Inspector, or Simulate + compress in Jobs).");
    ImGui::End();
    return;
  }
  try {
    if (o.loadedShape != o.shape) {
      const ObjectMesh m = makeObject(o.shape);
      o.mesh.set(m.vertices, m.indices);
      o.loadedShape = o.shape;
      o.distance = 3.2f * m.radius;
    }
    if (!o.program.valid() && o.programError.empty())
      o.program.build("btf_object", shaderSource("btf_object.vert"),
                      decoderFragment("btf_object.frag"));
  } catch (const std::exception& e) {
    o.programError = e.what();
  }
  if (!o.programError.empty()) {
    ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", o.programError.c_str());
    ImGui::End();
    return;
  }
  // The CPU render's image (uploaded once its job is done) takes the lower part of the panel.
  if (o.cpuDirty) {
    o.cpuDirty = false;
    try {
      int iw = 0, ih = 0;
      const std::vector<float> px = readRgbImage(o.cpuImagePath, &iw, &ih);
      std::vector<uint8_t> rgba(size_t(iw) * size_t(ih) * 4, 255);
      for (size_t p = 0; p < size_t(iw) * size_t(ih); ++p)
        for (int c = 0; c < 3; ++c)  // the PNG holds display values already
          rgba[p * 4 + size_t(c)] =
              uint8_t(std::lround(std::clamp(px[p * 3 + size_t(c)], 0.f, 1.f) * 255));
      o.cpuImage.setRgba8(iw, ih, rgba.data(), false);
    } catch (const std::exception& e) {
      app.act.message(e.what(), true);
    }
  }
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  float cpuH = 0;
  if (o.cpuImage.id() && o.cpuImage.width() > 0)
    cpuH = std::min(avail.y * 0.45f,
                    avail.x * float(o.cpuImage.height()) / float(o.cpuImage.width())) +
           ImGui::GetTextLineHeightWithSpacing() * 4;
  const float dispW = std::max(64.0f, avail.x), dispH = std::max(64.0f, avail.y - 4 - cpuH);
  const int w = std::max(32, int(dispW * o.renderScale)),
            h = std::max(32, int(dispH * o.renderScale));
  // The GPU decode is heavy on llvmpipe: render only when something changed.
  char key[512];
  std::snprintf(key, sizeof key, "%s|%s|%d|%d|%.4f|%.4f|%.4f|%.3f|%.3f|%.4f|%.4f|%d|%d|%d|%d",
                o.shape.c_str(), o.bound.c_str(), w, h, o.yaw, o.pitch, o.distance, o.lightTheta,
                o.lightPhi, o.exposure, o.tiling, o.toneMap, o.bilinear ? 1 : 0, o.mip ? 1 : 0,
                o.showLevel ? 1 : 0);
  // A changed view restarts the pass; the pass renders a band of rows per frame so the UI keeps
  // its frame rate while llvmpipe decodes (the status bar shows the whole pass's time).
  if (key != o.renderedKey || o.bound != app.insp.compressed) {
    o.renderedKey = key;
    o.band = 0;
    if (o.frameMs > 0) o.bands = std::clamp(int(std::ceil(o.frameMs / 20.0)), 1, 64);
    o.passMs = 0;
    o.fb.resize(w, h, false);
    o.fb.begin(0.08f, 0.08f, 0.1f, 1);
    gl::Framebuffer::end(app.width, app.height);
  }
  if (o.band >= 0) {
    const auto t0 = std::chrono::steady_clock::now();
    const glm::vec3 eye(o.distance * std::cos(o.pitch) * std::cos(o.yaw),
                        o.distance * std::cos(o.pitch) * std::sin(o.yaw),
                        o.distance * std::sin(o.pitch));
    const glm::mat4 proj =
        glm::perspective(glm::radians(35.0f), float(w) / float(h), 0.05f, 100.0f);
    const glm::mat4 view = glm::lookAt(eye, glm::vec3(0), glm::vec3(0, 0, 1));
    const glm::mat4 vp = proj * view, model(1.0f);
    const float lt = glm::radians(o.lightTheta), lp = glm::radians(o.lightPhi);
    const int y0 = h * o.band / o.bands, y1 = h * (o.band + 1) / o.bands;
    o.fb.bind();
    gl::begin3d();
    gl::scissor(0, y0, w, y1 - y0);
    try {
      bindDecoder(app, o.program, o.mip);
      o.program.set("u_showLevel", o.showLevel ? 1 : 0);
      o.program.setMat4("u_viewProj", glm::value_ptr(vp));
      o.program.setMat4("u_model", glm::value_ptr(model));
      o.program.set("u_lightDir", std::sin(lt) * std::cos(lp + o.yaw),
                    std::sin(lt) * std::sin(lp + o.yaw), std::cos(lt));
      o.program.set("u_eye", eye.x, eye.y, eye.z);
      o.program.set("u_tiling", o.tiling);
      o.program.set("u_exposure", o.exposure);
      o.program.set("u_toneMap", o.toneMap);
      o.program.set("u_bilinear", o.bilinear ? 1 : 0);
      o.mesh.draw();
    } catch (const std::exception& e) {
      o.programError = e.what();
    }
    gl::noScissor();
    gl::end3d();
    gl::finish();
    gl::Framebuffer::end(app.width, app.height);
    o.passMs +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (++o.band == o.bands) {
      o.band = -1;
      o.frameMs = o.passMs;
      app.act.report()["object_pass_ms"] = o.frameMs;
    }
  }
  ImGui::Image(o.fb.imguiId(), ImVec2(dispW, dispH), ImVec2(0, 1), ImVec2(1, 0));
  if (ImGui::IsItemActive() && ImGui::IsMouseDragging(0)) {
    const ImVec2 d = ImGui::GetIO().MouseDelta;
    o.yaw -= d.x * 0.01f;
    o.pitch = std::clamp(o.pitch + d.y * 0.01f, -1.4f, 1.4f);
  }
  if (ImGui::IsItemHovered() && ImGui::GetIO().MouseWheel != 0)
    o.distance *= std::pow(0.9f, ImGui::GetIO().MouseWheel);
  if (cpuH > 0) {
    const float ih = cpuH - ImGui::GetTextLineHeightWithSpacing() * 4;
    ImGui::Image(o.cpuImage.imguiId(),
                 ImVec2(ih * float(o.cpuImage.width()) / float(o.cpuImage.height()), ih));
    ImGui::TextUnformatted(o.cpuText.c_str());
  }
  ImGui::End();
}

}  // namespace btf::ui
