// The object viewer: the compressed BTF mapped on objects and decoded on the GPU by the GLSL in
// shaders/ (btf_decode.glsl: texture-buffer arrays, direction interpolation, bilinear texels),
// with per-pixel tangent frames, light and orbit-camera control, exposure and tone mapping.
// checkGlsl() renders the same decoder into a float framebuffer for comparison with the CPU.
#include <btf/compress/mip.h>
#include <btf/core/error.h>
#include <btf/core/format.h>
#include <btf/core/rng.h>
#include <btf/directions/direction_set.h>
#include <btf/io/image_io.h>
#include <btf/render/objects.h>
#include <btf/render/renderer.h>
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

// The decoder, then the given pieces, in one fragment shader.
std::string decoderFragment(std::initializer_list<const char*> pieces) {
  std::string src = "#version 330 core\n" + shaderSource("btf_decode.glsl") + "\n";
  for (const char* p : pieces) src += shaderSource(p) + "\n";
  return src;
}

// Uploads the compressed arrays as texture buffers and sets the decoder's uniforms; `levels`:
// a pyramid's texel levels too (docs/mip.md), else level 0 alone.
void bindDecoder(const ObjectView& app, const gl::Program& prog, bool levels) {
  ObjectState& o = app.obj;
  const CompressedBtf& c = *app.insp.cbtf;
  // neural: the network's shape from the file's params (the CPU decoder validated them).
  std::vector<int> nnSizes;
  int nnEnc = 0, nnMinimal = 0;
  if (c.codec == "neural") {
    const json p = json::parse(c.paramsJson);
    const std::string enc = p.at("encoding").get<std::string>();
    nnEnc = enc == "raw" ? 0 : enc == "halfdiff" ? 1 : 2;
    nnMinimal = p.contains("half_frame") && p["half_frame"] == "minimal" ? 1 : 0;
    const int hidden = p.at("hidden").get<int>(), layers = p.at("hidden_layers").get<int>();
    if (hidden > 128)
      throw Error(format("the GLSL neural decoder handles hidden layers of up to 128 units; this "
                         "file's have %d: use Render on CPU, or btfsim render",
                         hidden));
    nnSizes.push_back(p.at("latent").get<int>() + (nnEnc == 0 ? 6 : nnEnc == 1 ? 12 : 36));
    for (int i = 0; i < layers; ++i) nnSizes.push_back(hidden);
    nnSizes.push_back(3);
  }
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
        c.codec == "tensor" ? tensorGpuTables(c, o.gpuTableFloats) : TensorGpuTables{};
    o.tensorTables.clear();
    if (c.codec == "tensor")
      o.tensorTables = tables.projected                                  ? "projected_cores"
                       : !tables.texels.empty() && tables.texels[2] >= 0 ? "texel_matrices"
                                                                         : "coefficients";
    for (int ch = 0; ch < 3; ++ch) {
      if (c.codec == "nmf") {
        for (const char* w : {"basis_view", "basis_light", "coef_view", "coef_light"})
          add(channelArray(ch, w));
      } else if (c.codec == "tensor") {
        for (const char* w : {"view", "light", "core"}) add(channelArray(ch, w));
        addData(tables.clusters[ch].data(), tables.clusters[ch].size(), false);
      } else if (c.codec == "neural") {
        for (const char* w : {"neural.weights", "neural.latents", "neural.gain", "none"})
          add(ch == 0 ? w : "none");
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
    } else if (c.codec != "tensor" && c.codec != "neural") {
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
  prog.set("u_codec", c.codec == "neural" ? 5 : codec);
  if (c.codec == "neural") {
    int sizes[10] = {}, wOff[9] = {}, bOff[9] = {};
    int64_t off = 0;
    for (size_t l = 0; l + 1 < nnSizes.size(); ++l) {
      wOff[l] = int(off);
      off += int64_t(nnSizes[l]) * nnSizes[l + 1];
      bOff[l] = int(off);
      off += nnSizes[l + 1];
    }
    for (size_t l = 0; l < nnSizes.size(); ++l) sizes[l] = nnSizes[l];
    prog.set("u_nnLayers", int(nnSizes.size()) - 1);
    prog.setInts("u_nnSize", sizes, 10);
    prog.setInts("u_nnW", wOff, 9);
    prog.setInts("u_nnB", bOff, 9);
    prog.set("u_nnEnc", nnEnc);
    prog.set("u_nnMinimal", nnMinimal);
  }
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

constexpr uint64_t kShellBudget = uint64_t(1) << 30;  // the tile's triangles, the shell's

// The shell tables of the current object, tiling and relief scale for the mapped view (and the
// raw store's visibility map), rebuilt when one of them changes; false with o.shellError set
// when they cannot be built (no visibility map, a folding shell, …).
bool ensureShell(const ObjectView& app) {
  ObjectState& o = app.obj;
  char key[1024];
  std::snprintf(key, sizeof key, "%s|%.6f|%.6f|%s|%s", o.shape.c_str(), o.tiling, o.reliefScale,
                app.insp.compressed.c_str(), app.insp.reference.c_str());
  if (key == o.shellKey) return o.shellError.empty();
  o.shellKey = key;
  o.shellError.clear();
  try {
    const CompressedBtf& c = *app.insp.cbtf;
    const BtfTile tile = tileOfBtf(c.info, app.insp.compressed, kShellBudget);
    const RenderScene rs(btf::makeObject(o.shape), tile.geometry.Lx, tile.geometry.Ly,
                         tile.geometry.zmin, tile.geometry.zmax,
                         viewerRenderSettings(o, o.radius, 64, 64));
    VmfTable v;
    if (!tile.flat && c.hasVmf() && app.insp.reference.empty()) {
      // The file's own visibility map (every .cbtf written since 2026-12-07 carries it, in 8
      // bits); an open reference supplies its full-precision one instead, as `render --vmf`.
      v.nu = c.info.nu, v.nv = c.info.nv, v.nDirs = c.info.nDirs();
      v.map = c.vmf();
      const DirectionSet set = DirectionSet::fromName(c.info.directionSet);
      for (int d = 0; d < set.size(); ++d) v.dirZ.push_back(float(set[d].w.z));
    } else if (!tile.flat) {
      if (app.insp.reference.empty())
        throw Error(
            "the mapped view needs a visibility map and this .cbtf carries none (written "
            "before files carried theirs): compress it again, or open it with the raw store it "
            "was compressed from as its reference (Inspector)");
      v = readVmfTable(app.insp.reference, c.info, app.insp.compressed);
    }
    o.shell = rs.gpuTables();
    o.shellBuf.set(o.shell.data.data(), o.shell.data.size(), false);
    o.shell.data = {};
    o.shellHasVmf = !tile.flat;
    o.vmfDirZ = int(v.map.size());
    v.map.insert(v.map.end(), v.dirZ.begin(), v.dirZ.end());
    if (v.map.empty()) v.map.push_back(0);
    o.vmfBuf.set(v.map.data(), v.map.size(), false);
  } catch (const std::exception& e) {
    o.shellError = e.what();
  }
  return o.shellError.empty();
}

// The shell, the visibility map, the camera and the light of the mapped program (units 16, 17:
// the decoder holds 0–15).
void bindShell(const ObjectState& o, const gl::Program& prog, const RenderSettings& s) {
  prog.bindBuffer("u_shell", o.shellBuf, 16);
  prog.bindBuffer("u_vmf", o.vmfBuf, 17);
  const ShellGpuTables& g = o.shell;
  prog.set("u_oVertex", g.oVertex);
  prog.set("u_oFace", g.oFace);
  prog.set("u_oPrism", g.oPrism);
  prog.set("u_oFrame", g.oFrame);
  prog.set("u_oNormal", g.oNormal);
  prog.set("u_oNode", g.oNode);
  prog.set("u_oLeaf", g.oLeaf);
  prog.set("u_nNodes", g.nodes);
  prog.set("u_hasVmf", o.shellHasVmf ? 1 : 0);
  prog.set("u_oDirZ", o.vmfDirZ);
  prog.set("u_Lx", float(g.Lx));
  prog.set("u_Ly", float(g.Ly));
  prog.set("u_hlo", float(g.hlo));
  prog.set("u_hhi", float(g.hhi));
  // Float precision: a step of a few ulps of the camera distance past each crossed face (the
  // CPU's double march steps 2e-6 of the radius).
  const CameraFrame cam = cameraFrame(s, o.radius);
  prog.set("u_eps", float(std::max(g.eps, 4e-7 * glm::length(cam.pos))));
  const DVec3 L = lightDirection(s);
  prog.set("u_light", float(L.x), float(L.y), float(L.z));
  prog.set("u_camPos", float(cam.pos.x), float(cam.pos.y), float(cam.pos.z));
  prog.set("u_camFwd", float(cam.fwd.x), float(cam.fwd.y), float(cam.fwd.z));
  prog.set("u_camRight", float(cam.right.x), float(cam.right.y), float(cam.right.z));
  prog.set("u_camUp", float(cam.up.x), float(cam.up.y), float(cam.up.z));
  prog.set("u_hw", float(cam.hw));
  prog.set("u_hh", float(cam.hh));
  prog.set("u_persp", cam.perspective ? 1 : 0);
  prog.set("u_size", float(s.width), float(s.height));
  prog.set("u_passes", 3);
}

void buildMappedProgram(ObjectState& o) {
  if (!o.mappedProgram.valid())
    o.mappedProgram.build(
        "btf_mapped", shaderSource("fullscreen.vert"),
        decoderFragment({"btf_display.glsl", "btf_shell.glsl", "btf_mapped.frag"}));
}

}  // namespace

RenderSettings viewerRenderSettings(const ObjectState& o, double radius, int w, int h) {
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  RenderSettings s;
  s.width = w, s.height = h, s.spp = 1;
  s.perspective = true, s.fovDeg = 35;
  s.zoom = std::max(1e-3, 1.05 * radius / (std::sin(17.5 / kDeg) * o.distance));
  s.camTheta = 90 - o.pitch * kDeg, s.camPhi = o.yaw * kDeg;
  s.lightTheta = o.lightTheta, s.lightPhi = o.lightPhi + o.yaw * kDeg;
  s.tiling = o.tiling, s.reliefScale = o.reliefScale;
  s.mip = false;
  return s;
}

bool checkMapped(const ObjectView& app, int w, int h, double maxDiffering, double maxMismatch,
                 json* result) {
  if (!app.insp.cbtf) throw Error("check_mapped: open a compressed BTF first");
  ObjectState& o = app.obj;
  if (o.loadedShape != o.shape) throw Error("check_mapped: show the object first (object action)");
  if (!ensureShell(app)) throw Error("check_mapped: " + o.shellError);
  buildMappedProgram(o);
  const RenderSettings s = viewerRenderSettings(o, o.radius, w, h);
  // The GPU: linear radiance and coverage, one ray through each pixel's centre; level 0.
  gl::Framebuffer fb;
  fb.resize(w, h, true);
  fb.begin(0, 0, 0, 0);
  bindDecoder(app, o.mappedProgram, false);
  bindShell(o, o.mappedProgram, s);
  o.mappedProgram.set("u_raw", 1);
  o.mappedProgram.set("u_showLevel", 0);
  o.mappedProgram.set("u_bilinear", 1);
  const auto t0 = std::chrono::steady_clock::now();
  gl::drawFullscreen();
  const auto px = fb.readFloat();
  const double gpuMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  gl::Framebuffer::end(app.width, app.height);
  // The CPU: the renderer's mapped mode on the same view and file (one sample at each centre).
  const CompressedBtf& c = *app.insp.cbtf;
  const BtfTile tile = tileOfBtf(c.info, app.insp.compressed, kShellBudget);
  const RenderScene rs(btf::makeObject(o.shape), tile.geometry.Lx, tile.geometry.Ly,
                       tile.geometry.zmin, tile.geometry.zmax, s);
  const BtfSampler sampler(app.insp.compressed, tile.flat ? "" : app.insp.reference, tile.flat,
                           kShellBudget);
  const RenderImage cpu = rs.renderMapped(sampler, nullptr, nullptr);
  RenderImage gpu;
  gpu.width = w, gpu.height = h;
  gpu.rgb.resize(size_t(w) * size_t(h) * 3);
  gpu.alpha.resize(size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y)  // GL's row 0 is the bottom
    for (int x = 0; x < w; ++x) {
      const size_t src = (size_t(h - 1 - y) * size_t(w) + size_t(x)) * 4,
                   dst = size_t(y) * size_t(w) + size_t(x);
      for (int k = 0; k < 3; ++k) gpu.rgb[dst * 3 + size_t(k)] = px[src + size_t(k)];
      gpu.alpha[dst] = px[src + 3];
    }
  const ImageError e = compareImages(gpu, cpu);
  double maxAbs = 0, peak = 0;
  int64_t both = 0;
  for (size_t p = 0; p < gpu.alpha.size(); ++p) {
    if (!(gpu.alpha[p] >= 0.5f && cpu.alpha[p] >= 0.5f)) continue;
    ++both;
    for (int k = 0; k < 3; ++k) {
      const double g = gpu.rgb[p * 3 + size_t(k)], r = cpu.rgb[p * 3 + size_t(k)];
      maxAbs = std::max(maxAbs, std::abs(g - r));
      peak = std::max(peak, std::abs(r));
    }
  }
  // Pixels that differ by more than 1 % of the peak (a march decision taken differently in
  // float than in double: a shadow, a relief hit at a prism edge).
  int64_t differing = 0;
  for (size_t p = 0; p < gpu.alpha.size(); ++p) {
    if (!(gpu.alpha[p] >= 0.5f && cpu.alpha[p] >= 0.5f)) continue;
    double d = 0;
    for (int k = 0; k < 3; ++k)
      d = std::max(d, double(std::abs(gpu.rgb[p * 3 + size_t(k)] - cpu.rgb[p * 3 + size_t(k)])));
    if (d > 0.01 * peak) ++differing;
  }
  *result = {{"object", o.shape},
             {"size", {w, h}},
             {"covered_pixels_cpu", e.refPixels},
             {"covered_pixels_both", both},
             {"coverage_mismatch", e.coverageMismatch},
             {"mismatch_pixels", e.mismatchPixels},
             {"rel_rmse", e.relRmse},
             {"rel_rmse_interior", e.relRmseInterior},
             {"max_abs", maxAbs},
             {"peak", peak},
             {"differing_pixels", differing},
             {"gpu_ms", gpuMs},
             {"cpu_ms", cpu.seconds * 1000},
             {"max_differing", maxDiffering},
             {"max_mismatch", maxMismatch}};
  return e.refPixels > 0 && double(differing) <= maxDiffering * double(both) &&
         e.coverageMismatch <= maxMismatch;
}

bool checkGlsl(const ObjectView& app, int samples, double tolerance, json* result) {
  if (!app.insp.cbtf || !app.insp.decoder) throw Error("check_glsl: open a compressed BTF first");
  gl::Program prog;
  prog.build("btf_check", shaderSource("fullscreen.vert"), decoderFragment({"btf_check.frag"}));
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
  if (cb.codec == "tensor") (*result)["tensor_tables"] = app.obj.tensorTables;
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
  ImGui::SetNextItemWidth(80);
  ImGui::Combo("view", &o.view, "flat\0mapped\0");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "flat: the BTF on the base surface. mapped: rays marched through the shell of the "
        "relief (silhouettes, the relief's own shadows; needs the raw store's visibility map, "
        "docs/render.md)");
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
      o.radius = m.radius;
    }
    if (!o.program.valid() && o.programError.empty())
      o.program.build("btf_object", shaderSource("btf_object.vert"),
                      decoderFragment({"btf_display.glsl", "btf_object.frag"}));
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
  std::snprintf(key, sizeof key,
                "%s|%s|%d|%d|%.4f|%.4f|%.4f|%.3f|%.3f|%.4f|%.4f|%d|%d|%d|%d|%d|%.4f|%s",
                o.shape.c_str(), o.bound.c_str(), w, h, o.yaw, o.pitch, o.distance, o.lightTheta,
                o.lightPhi, o.exposure, o.tiling, o.toneMap, o.bilinear ? 1 : 0, o.mip ? 1 : 0,
                o.showLevel ? 1 : 0, o.view, o.reliefScale, app.insp.reference.c_str());
  // The mapped view: the shell's tables (rebuilt when the object, tiling or relief changes) and
  // its program; a message instead of the image when they cannot be made.
  const bool mapped = o.view == 1;
  if (mapped) {
    try {
      buildMappedProgram(o);
    } catch (const std::exception& e) {
      o.programError = e.what();
    }
    if (!ensureShell(app)) {
      ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "mapped view: %s", o.shellError.c_str());
      ImGui::End();
      return;
    }
  }
  // A changed view restarts the pass; the pass renders a band of rows per frame so the UI keeps
  // its frame rate while llvmpipe decodes (the status bar shows the whole pass's time). Each
  // band's height follows the cost per row measured on the band before (at most doubling from
  // one band to the next: rows of background cost little, rows through the object much more),
  // aiming at o.bandMs a frame.
  const double kBandMs = o.bandMs;
  const int vi = mapped ? 1 : 0;
  if (key != o.renderedKey || o.bound != app.insp.compressed) {
    o.renderedKey = key;
    o.band = 0;
    o.bands = 0;
    o.bandRows = o.rowMs[vi] > 0 ? std::clamp(int(kBandMs / o.rowMs[vi]), 1, h) : (mapped ? 2 : 8);
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
    const int y0 = std::min(o.band, h), y1 = std::min(h, y0 + std::max(1, o.bandRows));
    o.fb.bind();
    gl::begin3d();
    gl::scissor(0, y0, w, y1 - y0);
    try {
      if (mapped) {
        const gl::Program& mp = o.mappedProgram;
        bindDecoder(app, mp, o.mip);
        bindShell(o, mp, viewerRenderSettings(o, o.radius, w, h));
        mp.set("u_raw", 0);
        mp.set("u_showLevel", o.showLevel ? 1 : 0);
        mp.set("u_bilinear", o.bilinear ? 1 : 0);
        mp.set("u_exposure", o.exposure);
        mp.set("u_toneMap", o.toneMap);
        gl::drawFullscreen();
      } else {
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
      }
    } catch (const std::exception& e) {
      o.programError = e.what();
    }
    gl::noScissor();
    gl::end3d();
    gl::finish();
    gl::Framebuffer::end(app.width, app.height);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    o.passMs += ms;
    if (o.bands == 0)  // the first band of a pass (a new program's compile lands here)
      app.act.report()[mapped ? "object_first_band_ms_mapped" : "object_first_band_ms"] = ms;
    ++o.bands;
    o.rowMs[vi] = ms / double(y1 - y0);
    o.bandRows = std::clamp(int(kBandMs / std::max(o.rowMs[vi], 1e-3)), 1, 2 * (y1 - y0));
    o.band = y1;
    if (o.band >= h) {
      o.band = -1;
      o.frameMs = o.passMs;
      app.act.report()[mapped ? "object_pass_ms_mapped" : "object_pass_ms"] = o.frameMs;
      app.act.report()["object_pass_bands"] = o.bands;
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
