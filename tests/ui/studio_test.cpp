// The real app under Xvfb (Mesa llvmpipe), driven by `btfstudio --script`: every resource scene
// edited and restored by undo, screenshots that are not blank with a known pixel, a simulation,
// compression, comparison, study and export run to the end with every panel open, the GLSL
// decoder checked against the CPU decoder, cancellation within a second, job errors, no display.
#include <btf/compress/codec.h>
#include <btf/io/image_io.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_util.h"

using namespace btf;
using namespace btf::test;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

// Runs the app under xvfb-run and returns the app's own exit status, printed by the shell inside
// xvfb-run: xvfb-run's status can be its own (5 when removing its temporary folder races).
int runStudio(const json& script, const fs::path& dir, std::string* log,
              const std::string& env = "") {
  const fs::path s = dir / "script.json", l = dir / "studio.log";
  std::ofstream(s) << script.dump(2);
  const std::string cmd =
      env + " xvfb-run -a -s \"-screen 0 1280x800x24\" sh -c '" BTF_STUDIO " --script " +
      s.string() + "; echo \"btfstudio-exit=$?\"' > " + l.string() + " 2>&1";
  for (int attempt = 0; attempt < 2; ++attempt) {
    std::system(cmd.c_str());
    *log = readFile(l);
    const auto k = log->rfind("btfstudio-exit=");
    if (k != std::string::npos) return std::atoi(log->c_str() + k + 15);
    // The app never ran (xvfb-run could not bring up a server): one retry.
  }
  return 128;
}

// Not blank: the image has structure (a spread of values), not one flat colour.
void expectNotBlank(const fs::path& png) {
  int w = 0, h = 0;
  const auto px = readRgbImage(png.string(), &w, &h);
  ASSERT_EQ(w, 1280) << png;
  ASSERT_EQ(h, 800);
  double sum = 0, sum2 = 0;
  for (float v : px) sum += v, sum2 += double(v) * v;
  const double mean = sum / double(px.size());
  EXPECT_GT(std::sqrt(sum2 / double(px.size()) - mean * mean), 0.05) << png << " looks blank";
}

std::string sceneFile(const std::string& name) {
  return sourceDir() + "/resources/scenes/" + name + ".json";
}

// Script actions: open a resource scene, simulate it (16² texels, 4x8 directions) to OUT.btf,
// compress that with nmf 1:20 to OUT.cbtf (each job waited for and expected done), and open the
// compressed file with its raw store as the reference.
void simulateCompressOpen(json& a, const std::string& scene, const std::string& out) {
  a.push_back({{"open", sceneFile(scene)}});
  a.push_back({{"simulate", {{"output", out + ".btf"}, {"texels", 16}, {"directions", "4x8"}}},
               {"wait", 300}});
  a.push_back({{"expect_job", {{"status", "done"}}}});
  a.push_back({{"compress",
                {{"input", out + ".btf"},
                 {"output", out + ".cbtf"},
                 {"codec", "nmf"},
                 {"target_ratio", 20}}},
               {"wait", 300}});
  a.push_back({{"expect_job", {{"status", "done"}}}});
  a.push_back({{"open_compressed", out + ".cbtf"}, {"reference", out + ".btf"}});
}

}  // namespace

TEST(Studio, EveryResourceSceneEditsUndoesAndScreenshots) {
  const auto dir = tempDir("ui_studio_scenes");
  json a = json::array();
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(sourceDir() + "/resources/scenes"))
    names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  ASSERT_GE(names.size(), 10u);
  // The previews' images (every effect of each scene's plan), not their texel matrices: one
  // texel's 96 × 96 pairs with interreflection take ~20 s a scene here, and are checked against
  // the simulator by the preview tests.
  a.push_back({{"directions", {{"size", 32}}}});
  for (const auto& n : names) {
    a.push_back({{"open", sceneFile(n)}});
    a.push_back({{"wait_preview", 240}, {"stage", "image"}});
    a.push_back({{"set", "/parts/0/transform/translate"}, {"value", {0.0, 0.0, 0.01}}});
    a.push_back({{"undo", 1}});
    a.push_back({{"expect_original", true}});
    a.push_back({{"wait_preview", 240}, {"stage", "image"}});
    a.push_back({{"screenshot", (dir / (n + ".png")).string()}});
  }
  std::string log;
  ASSERT_EQ(runStudio(a, dir, &log), 0) << log;
  for (const auto& n : names) expectNotBlank(dir / (n + ".png"));
}

TEST(Studio, FlatLambertPreviewPixelIsTheAlbedo) {
  // The default scene is a flat Lambert tile of albedo 0.8: aBRDF 0.8/π, shown × π → 0.8, sRGB
  // 0.906 → 231 in every channel, whatever the light.
  const auto dir = tempDir("ui_studio_lambert");
  json a = json::array({{{"new", true}},
                        {{"directions", {{"light", {50.0, 120.0}}, {"view", {20.0, 10.0}}}}},
                        {{"wait_preview", 60}},
                        {{"screenshot", (dir / "lambert.png").string()}},
                        {{"drop", {sourceDir() + "/resources/meshes/pyramid.obj"}}},
                        {{"expect_parts", 2}},
                        {{"undo", 1}},
                        {{"expect_parts", 1}},
                        {{"drop", {sourceDir() + "/resources/scenes/sine.json"}}},
                        {{"expect_parts", 1}},
                        {{"save", (dir / "saved.json").string()}},
                        {{"report", (dir / "report.json").string()}}});
  std::string log;
  ASSERT_EQ(runStudio(a, dir, &log), 0) << log;
  EXPECT_NE(readFile(dir / "saved.json").find("\"sine\""), std::string::npos)
      << "the dropped scene was not opened";
  const json r = json::parse(readFile(dir / "report.json"));
  const auto rect = r.at("preview_rect");
  int w = 0, h = 0;
  const auto px = readRgbImage((dir / "lambert.png").string(), &w, &h);
  // A quarter in from the corner: the centre carries the picked-texel marker.
  const int cx = int(0.75 * rect[0].get<double>() + 0.25 * rect[2].get<double>());
  const int cy = int(0.75 * rect[1].get<double>() + 0.25 * rect[3].get<double>());
  for (int c = 0; c < 3; ++c) {
    const float v = px[(size_t(cy) * w + cx) * 3 + c];  // the PNG's byte / 255
    EXPECT_NEAR(v * 255, 255 * linearToSrgb(0.8f), 1.01) << "channel " << c;
  }
  expectNotBlank(dir / "lambert.png");
}

// The tensor GLSL decoder's two table layouts against the CPU decoder: every cluster's projected
// cores G (Rt products per value; when they fit in 16 M floats) and, when they do not (8
// components in 4 clusters at 16×32 directions: 96 · 512² floats), the per-texel matrices M.
TEST(Studio, TheTensorGlslDecoderMatchesTheCpuWithEitherTable) {
  const auto dir = tempDir("ui_studio_tensor_tables");
  const std::string raw = (dir / "b.btf").string(), g = (dir / "g.cbtf").string(),
                    m = (dir / "m.cbtf").string();
  std::string out;
  ASSERT_EQ(runBtfsim("simulate " + sceneFile("brick") + " -o " + raw +
                          " --texels 8 --dirs 8x16 --spp 1 -q",
                      &out),
            0)
      << out;
  ASSERT_EQ(runBtfsim("compress " + raw + " -o " + g + " --codec tensor -q", &out), 0) << out;
  ASSERT_EQ(
      runBtfsim("compress " + raw + " -o " + m + " --codec tensor --clusters 4 --components 8 -q",
                &out),
      0)
      << out;
  json a = json::array();
  // The tables' budget at 2 MiB (64 by default): at 128 directions the default codec's projected
  // cores (n² × ΣRt = 16384 × 24 floats) fit and the 4 × 8 ranks' (× 96) do not, so the second
  // file takes the per-texel matrices — the switch a 64 MiB budget makes at 512 directions,
  // without their 16x32 simulation and compressions (15 s of this test).
  for (const auto& [file, name] : {std::pair{g, "g"}, std::pair{m, "m"}}) {
    a.push_back({{"open_compressed", file}, {"reference", raw}, {"gpu_table_mib", 2}});
    a.push_back({{"check_glsl", {{"samples", 512}, {"tolerance", 2e-3}, {"name", name}}}});
  }
  a.push_back({{"report", (dir / "report.json").string()}});
  std::string log;
  ASSERT_EQ(runStudio(a, dir, &log), 0) << log;
  for (const auto& [name, tables] :
       {std::pair{"g", "projected_cores"}, std::pair{"m", "texel_matrices"}}) {
    const json r = json::parse(readFile(dir / "report.json")).at("check_glsl_" + std::string(name));
    EXPECT_EQ(r["tensor_tables"], tables) << r.dump();
    EXPECT_EQ(r["samples"], 512);
    EXPECT_GT(r["peak"].get<double>(), 0.01) << r.dump();
    EXPECT_LE(r["max_rel_to_peak"].get<double>(), 2e-3) << r.dump();
  }
}

// The neural GLSL decoder (continuous in direction, no interpolation between the set's) against
// the CPU decoder on random lookups: the default encoding (fourier) and, on a pyramid, halfdiff
// with three hidden layers — every level and the CPU's level choice.
TEST(Studio, TheNeuralGlslDecoderMatchesTheCpu) {
  const auto dir = tempDir("ui_studio_neural");
  const std::string raw = (dir / "b.btf").string(), f = (dir / "f.cbtf").string(),
                    h = (dir / "h.cbtf").string();
  std::string out;
  ASSERT_EQ(runBtfsim("simulate " + sceneFile("brick") + " -o " + raw +
                          " --texels 8 --dirs 4x8 --spp 1 -q",
                      &out),
            0)
      << out;
  ASSERT_EQ(runBtfsim("compress " + raw + " -o " + f + " --codec neural --neural-steps 200 -q",
                      &out),
            0)
      << out;
  ASSERT_EQ(runBtfsim("compress " + raw + " -o " + h +
                          " --codec neural --neural-steps 200 --encoding halfdiff "
                          "--hidden 24 --hidden-layers 3 --mip -q",
                      &out),
            0)
      << out;
  json a = json::array();
  for (const auto& [file, name] : {std::pair{f, "f"}, std::pair{h, "h"}}) {
    a.push_back({{"open_compressed", file}, {"reference", raw}});
    a.push_back({{"check_glsl", {{"samples", 512}, {"tolerance", 2e-3}, {"name", name}}}});
  }
  a.push_back({{"report", (dir / "report.json").string()}});
  std::string log;
  ASSERT_EQ(runStudio(a, dir, &log), 0) << log;
  const json r = json::parse(readFile(dir / "report.json"));
  for (const char* name : {"f", "h"}) {
    const json g = r.at("check_glsl_" + std::string(name));
    EXPECT_EQ(g["samples"], 512);
    EXPECT_GT(g["peak"].get<double>(), 0.01) << g.dump();
    EXPECT_LE(g["max_rel_to_peak"].get<double>(), 2e-3) << g.dump();
  }
  const json gh = r.at("check_glsl_h");
  EXPECT_GE(gh["levels"].get<int>(), 3) << gh.dump();
  EXPECT_LE(gh["max_lod_difference"].get<double>(), 1e-3) << gh.dump();
}

TEST(Studio, SimulateCompressInspectStudyExportAndTheGlslDecoder) {
  const auto dir = tempDir("ui_studio_jobs");
  const std::string out = (dir / "brick").string();
  json a = json::array();
  simulateCompressOpen(a, "brick", out);
  a.push_back({{"compare", true}, {"wait", 300}});
  // The neural codec's row with 300 training steps (of 4000): its decoder and metrics are under
  // test here, not its accuracy (28 s of the sweep's 34 at the default).
  a.push_back({{"codec_options", {{"neural_steps", 300}}}});
  a.push_back({{"codec_sweep", out + ".btf"}, {"wait", 600}});
  a.push_back({{"expect_codec_rows", int(codecNames().size())}});
  a.push_back({{"panel", "Inspector"}});
  a.push_back({{"screenshot", (dir / "inspector.png").string()}});
  a.push_back({{"check_glsl", {{"samples", 512}, {"tolerance", 2e-3}}}});
  // The object passes at a quarter of the panel's pixels (its slider's lowest; the default is a
  // half): the screenshots need each object drawn by the decoder, not at full resolution — under
  // llvmpipe a pass at the default took 2–6 s (a third of this test's CPU time). The decoder's
  // values are checked by check_glsl, the march by the mapped-view test's check_mapped.
  for (const char* o : {"plane", "sphere", "cylinder", "vase", "cushion", "chair"}) {
    a.push_back({{"panel", "Objects"}});
    a.push_back({{"object", o}, {"render_scale", 0.25}});
    a.push_back({{"frames", 3}});
    a.push_back({{"screenshot", (dir / (std::string("object_") + o + ".png")).string()}});
  }
  // The same view on the CPU renderer: exact | mapped | flat, with the errors in the report.
  a.push_back({{"object", "sphere"}});
  a.push_back({{"render_objects",
                {{"mode", "all"}, {"spp", 1}, {"size", 64}, {"output", out + "-objects.png"}}},
               {"wait", 300}});
  a.push_back({{"expect_job", {{"status", "done"}}}});
  a.push_back({{"frames", 3}});
  a.push_back({{"screenshot", (dir / "object_cpu.png").string()}});
  a.push_back({{"study", {{"dir", out + "-study"}}}, {"wait", 600}});
  a.push_back({{"expect_job", {{"status", "done"}}}});
  a.push_back({{"panel", "Study"}});
  a.push_back({{"screenshot", (dir / "study.png").string()}});
  a.push_back(
      {{"export", {{"input", out + ".cbtf"}, {"format", "ubo2014"}, {"output", out + ".dfmf"}}},
       {"wait", 300}});
  a.push_back({{"expect_job", {{"status", "done"}}}});
  a.push_back({{"expect_exists", out + ".dfmf"}});
  a.push_back({{"simulate",
                {{"output", out + "-streamed.cbtf"},
                 {"texels", 16},
                 {"directions", "4x8"},
                 {"stream", true},
                 {"codec", "nmf"}}},
               {"wait", 300}});
  a.push_back({{"expect_job", {{"status", "done"}}}});
  a.push_back({{"expect_exists", out + "-streamed.cbtf"}});
  a.push_back({{"expect_missing", out + "-streamed.btf"}});
  for (const char* p : {"Scene", "Tile view", "Preview", "BRDF", "Jobs"})
    a.push_back({{"panel", p}});
  a.push_back({{"screenshot", (dir / "jobs.png").string()}});
  // The tensor codec's GLSL decoder (the codec sweep wrote its file) against its CPU decoder.
  a.push_back({{"open_compressed", out + ".tensor.cbtf"}, {"reference", out + ".btf"}});
  a.push_back({{"check_glsl", {{"samples", 512}, {"tolerance", 2e-3}}}});
  // A pyramid (compress --mip): the GLSL level selection and filtered decode against the CPU's,
  // and the sphere far away in false colour (levels rising toward the silhouette).
  a.push_back({{"compress",
                {{"input", out + ".btf"},
                 {"output", out + ".mip.cbtf"},
                 {"codec", "tensor"},
                 {"mip", true}}},
               {"wait", 300}});
  a.push_back({{"expect_job", {{"status", "done"}}}});
  a.push_back({{"check_glsl", {{"samples", 512}, {"tolerance", 2e-3}}}});
  a.push_back({{"panel", "Objects"}});
  a.push_back({{"object", "sphere"}, {"show_level", true}, {"tiling", 16}});
  a.push_back({{"frames", 3}});
  a.push_back({{"screenshot", (dir / "object_levels.png").string()}});
  a.push_back({{"object", "sphere"}, {"show_level", false}});
  a.push_back({{"frames", 3}});
  a.push_back({{"screenshot", (dir / "object_mip.png").string()}});
  a.push_back({{"report", (dir / "report.json").string()}});
  std::string log;
  ASSERT_EQ(runStudio(a, dir, &log), 0) << log;
  const json r = json::parse(readFile(dir / "report.json"));
  const json gt = r.at("check_glsl_tensor");
  EXPECT_GT(gt["peak"].get<double>(), 0.01);
  // The last check is the pyramid's: every level, the CPU's level choice to 1e-3.
  const json gm = r.at("check_glsl_tensor_mip");
  EXPECT_GE(gm["levels"].get<int>(), 4) << gm.dump();
  EXPECT_LE(gm["max_lod_difference"].get<double>(), 1e-3) << gm.dump();
  EXPECT_LE(gm["max_rel_to_peak"].get<double>(), 2e-3) << gm.dump();
  EXPECT_LE(gt["max_rel_to_peak"].get<double>(), 2e-3) << gt.dump();
  // The shader read every cluster's projected cores (Rt products per value), not the M path.
  EXPECT_EQ(gt["tensor_tables"], "projected_cores") << gt.dump();
  const json g = r.at("check_glsl_nmf");
  EXPECT_EQ(g["samples"], 512);
  EXPECT_GT(g["peak"].get<double>(), 0.01);
  EXPECT_LE(g["max_rel_to_peak"].get<double>(), 2e-3) << g.dump();
  const json ro = r.at("object_render");
  ASSERT_EQ(ro["images"].size(), 3u) << ro.dump();
  EXPECT_EQ(ro["object"], "sphere");
  for (int k = 1; k < 3; ++k) {  // mapped and flat measured against the exact image
    const double e = ro["images"][k]["error_vs_exact"]["rel_rmse"].get<double>();
    EXPECT_TRUE(std::isfinite(e) && e < 1.0) << ro.dump();
  }
  for (const char* f : {"-objects.png", "-objects.exact.exr", "-objects.mapped.exr"})
    EXPECT_TRUE(fs::exists(out + f)) << f;
  for (const char* s :
       {"inspector", "object_plane", "object_sphere", "object_vase", "object_cushion",
        "object_chair", "object_cpu", "study", "jobs", "object_levels", "object_mip"})
    expectNotBlank(dir / (std::string(s) + ".png"));
  std::cout << "GLSL vs CPU decoder: " << g.dump() << "\n";
}

TEST(Studio, MappedViewMarchesTheShellAsTheCpuRendererDoesPixelByPixel) {
  // The GLSL shell march (shaders/btf_shell.glsl) against RenderScene::renderMapped on the same
  // view, one ray through each pixel's centre: brick on a sphere, the vase (non-convex: shadows
  // cast by other parts of the object) and the hills with the relief doubled; the spheres tile
  // (relief that is not a height field) on the curved section.
  const auto dir = tempDir("ui_studio_mapped");
  json a = json::array();
  // The BRDF panel closed: the scenes' previews (beside their simulations) are images alone.
  a.push_back({{"layout", {"Scene", "Tile view", "Preview", "Jobs"}}});
  for (const char* scene : {"brick", "spheres"})
    simulateCompressOpen(a, scene, (dir / scene).string());
  a.push_back({{"panel", "Objects"}});
  // The spheres last opened: the section seen low.
  // The panel's passes at a quarter of its pixels (as in the test above); check_mapped renders
  // at its own size.
  a.push_back({{"object", "section"},
               {"view", "mapped"},
               {"tiling", 3},
               {"pitch", 0.3},
               {"render_scale", 0.25}});
  a.push_back({{"check_mapped", {{"size", {80, 60}}}}});
  a.push_back({{"screenshot", (dir / "spheres_section.png").string()}});
  const std::string brick = (dir / "brick").string();
  a.push_back({{"open_compressed", brick + ".cbtf"}, {"reference", brick + ".btf"}});
  a.push_back({{"object", "sphere"}, {"view", "mapped"}, {"tiling", 4}, {"pitch", 0.5}});
  a.push_back({{"check_mapped", {{"size", {80, 60}}}}});
  a.push_back({{"screenshot", (dir / "brick_sphere.png").string()}});
  a.push_back({{"object", "vase"}, {"view", "mapped"}, {"tiling", 4}});
  a.push_back({{"check_mapped", {{"size", {80, 60}}}}});
  a.push_back({{"object", "hills"}, {"pitch", 0.3}, {"relief_scale", 2}});
  a.push_back({{"check_mapped", {{"size", {80, 60}}}}});
  // Frames while a mapped pass and an exact CPU render run (reported, docs/performance.md).
  a.push_back({{"object", "sphere"}, {"relief_scale", 1}, {"light_theta", 60}});
  a.push_back({{"render_objects", {{"mode", "exact"}, {"spp", 16}, {"size", 128}}}});
  a.push_back({{"object", "sphere"}, {"light_theta", 30}, {"wait", 0}});
  a.push_back({{"measure_frames", 2.0}});
  a.push_back({{"report", (dir / "report.json").string()}});
  std::string log;
  ASSERT_EQ(runStudio(a, dir, &log), 0) << log;
  const json r = json::parse(readFile(dir / "report.json"));
  for (const char* o : {"section", "sphere", "vase", "hills"}) {
    const json c = r.at(std::string("check_mapped_") + o);
    // The same silhouette and the same shading: coverage to 1 %, at most 0.5 % of the pixels
    // more than 1 % of the peak apart (a decision taken in float on the GPU, in double on the
    // CPU) — the check's own thresholds, restated.
    EXPECT_GT(c["covered_pixels_cpu"].get<int>(), 200) << o << c.dump();
    EXPECT_LE(c["coverage_mismatch"].get<double>(), 0.01) << o << c.dump();
    EXPECT_LE(c["differing_pixels"].get<double>(), 0.005 * c["covered_pixels_both"].get<double>())
        << o << c.dump();
    EXPECT_GT(c["peak"].get<double>(), 0.01) << o << c.dump();
    std::cout << "GLSL march vs CPU (" << o << "): " << c.dump() << "\n";
  }
  // Brick and its own shading: the two agree to float rounding.
  EXPECT_LE(r.at("check_mapped_sphere")["rel_rmse_interior"].get<double>(), 1e-3);
  EXPECT_GT(r.at("object_pass_ms_mapped").get<double>(), 0);
  std::cout << "frames during a mapped pass and an exact render: " << r.at("frames").dump() << "\n";
  expectNotBlank(dir / "brick_sphere.png");
  expectNotBlank(dir / "spheres_section.png");

  // Without the raw store: the file's own (8-bit) visibility map, on the GPU and the CPU alike.
  json b = json::array();
  b.push_back({{"open_compressed", brick + ".cbtf"}});
  b.push_back({{"panel", "Objects"}});
  b.push_back({{"object", "sphere"},
               {"view", "mapped"},
               {"tiling", 4},
               {"pitch", 0.5},
               {"render_scale", 0.25}});
  b.push_back({{"check_mapped", {{"size", {80, 60}}}}});
  b.push_back({{"report", (dir / "alone.json").string()}});
  ASSERT_EQ(runStudio(b, dir, &log), 0) << log;
  const json alone = json::parse(readFile(dir / "alone.json")).at("check_mapped_sphere");
  EXPECT_GT(alone["covered_pixels_cpu"].get<int>(), 200) << alone.dump();
  EXPECT_LE(alone["rel_rmse_interior"].get<double>(), 1e-3) << alone.dump();
  // A .cbtf without a map of its own (written before files carried theirs) and no raw store:
  // a clear message.
  CompressedBtf old = readCompressed(brick + ".cbtf");
  old.vmfCoded.clear();
  writeCompressed((dir / "old.cbtf").string(), old);
  json c = json::array();
  c.push_back({{"open_compressed", (dir / "old.cbtf").string()}});
  c.push_back({{"panel", "Objects"}});
  c.push_back({{"object", "sphere"}, {"view", "mapped"}, {"render_scale", 0.25}});
  c.push_back({{"check_mapped", {{"size", {32, 24}}}}});
  EXPECT_NE(runStudio(c, dir, &log), 0) << log;
  EXPECT_NE(log.find("visibility map"), std::string::npos) << log;
}

TEST(Studio, CancelStopsWithinASecondLeavesNoPartialAndJobErrorsKeepTheScene) {
  const auto dir = tempDir("ui_studio_cancel");
  const std::string out = (dir / "big.btf").string();
  json a = json::array();
  // The BRDF panel closed before the scene opens: its preview is the image alone (the texel
  // matrix, 6 s of this test, is not what it measures).
  a.push_back({{"layout", {"Scene", "Tile view", "Preview", "Jobs"}}});
  a.push_back({{"open", sceneFile("brick")}});
  a.push_back({{"wait_preview", 120}});
  a.push_back({{"simulate", {{"output", out}, {"texels", 128}, {"directions", "bonn81"}}}});
  a.push_back({{"sleep", 1.5}});
  a.push_back({{"measure_frames", 2.0}});
  a.push_back({{"cancel", "last"}, {"within", 1.0}});
  a.push_back({{"expect_job", {{"status", "cancelled"}}}});
  a.push_back({{"expect_missing", out}});
  a.push_back({{"expect_missing", out + ".partial"}});
  a.push_back({{"simulate", {{"output", (dir / "bad.btf").string()}, {"directions", "bogus"}}},
               {"wait", 60}});
  a.push_back({{"expect_job", {{"status", "failed"}, {"message", "bogus"}}}});
  a.push_back({{"expect_original", true}});
  a.push_back({{"screenshot", (dir / "after_error.png").string()}});
  a.push_back({{"report", (dir / "report.json").string()}});
  std::string log;
  ASSERT_EQ(runStudio(a, dir, &log), 0) << log;
  const json r = json::parse(readFile(dir / "report.json"));
  EXPECT_LE(r.at("cancel_seconds").get<double>(), 1.0);
  // Frame times while the simulation runs are reported, not asserted (docs/performance.md).
  std::cout << "frames during a simulation: " << r.at("frames").dump() << "\n";
  expectNotBlank(dir / "after_error.png");
}

TEST(Studio, TheBrdfSliceIsComputedOnlyWhileItsPanelIsOpen) {
  // The preview's BRDF slice and texel matrix are for the BRDF panel alone: with it closed the
  // preview finishes without them; opening it requests them.
  const auto dir = tempDir("ui_studio_brdf_gate");
  const std::string b = (dir / "brdf.json").string();
  std::string log;
  // The first frame's request was made with the panel open (the default layout): a new light
  // direction is the request made with it closed.
  json closed = json::array({{{"new", true}},
                             {{"layout", {"Scene", "Preview"}}},
                             {{"directions", {{"light", {40.0, 10.0}}}}},
                             {{"wait_preview", 60}},
                             {{"save_brdf", b}}});
  EXPECT_EQ(runStudio(closed, dir, &log), 1);
  EXPECT_NE(log.find("no BRDF slice yet"), std::string::npos) << log;
  json opened = json::array({{{"new", true}},
                             {{"layout", {"Scene", "Preview"}}},
                             {{"directions", {{"light", {40.0, 10.0}}}}},
                             {{"wait_preview", 60}},
                             {{"panel", "BRDF"}},
                             {{"wait_preview", 60}},
                             {{"save_brdf", b}}});
  ASSERT_EQ(runStudio(opened, dir, &log), 0) << log;
  const json r = json::parse(readFile(b));
  EXPECT_FALSE(r.at("values").empty()) << r.dump();
}

TEST(Studio, TheTileViewIsDrawnOnlyWhenWhatItShowsChanges) {
  // Nine copies of the tile's mesh are drawn again only when the scene, the camera, the light or
  // the panel's size changed; frames in between show the framebuffer kept (an idle studio under
  // a software renderer spent most of its time there).
  const auto dir = tempDir("ui_studio_tile_draws");
  std::string log;
  auto draws = [&](bool moveLight) {
    json a = json::array({{{"new", true}}, {{"frames", 40}}});
    if (moveLight) {
      a.push_back({{"directions", {{"light", {50.0, 120.0}}}}});
      a.push_back({{"frames", 5}});
    }
    a.push_back({{"report", (dir / "r.json").string()}});
    EXPECT_EQ(runStudio(a, dir, &log), 0) << log;
    return json::parse(readFile(dir / "r.json"));
  };
  const json still = draws(false), moved = draws(true);
  EXPECT_GE(still.at("frames_drawn").get<int>(), 40) << still.dump();
  // The first frames settle the window's layout (a new size each): a few draws, not forty.
  EXPECT_GE(still.at("tile_view_draws").get<int>(), 1) << still.dump();
  EXPECT_LE(still.at("tile_view_draws").get<int>(), 4) << still.dump();
  // A new light direction (the line drawn from the tile's centre) is one more draw.
  EXPECT_EQ(moved.at("tile_view_draws").get<int>(), still.at("tile_view_draws").get<int>() + 1)
      << moved.dump();
}

TEST(Studio, AnIdleSessionWaitsForEventsAndAJobRedrawsTenTimesASecond) {
  // A user's session (the pacing {"interactive": s} gives a script): with nothing running the
  // studio sleeps until an event or half a second, where a script's sleep draws every frame it
  // can; while a job runs, ten frames a second at most.
  const auto dir = tempDir("ui_studio_idle");
  std::string log;
  auto frames = [&](bool job) {
    json a = json::array({{{"new", true}}, {{"wait_preview", 60}}});
    if (job)
      a.push_back({{"simulate",
                    {{"output", (dir / "x.btf").string()}, {"texels", 64}, {"directions", "bonn81"}}}});
    a.push_back({{"interactive", 2.0}});
    if (job) a.push_back({{"cancel", "last"}});
    a.push_back({{"report", (dir / "r.json").string()}});
    EXPECT_EQ(runStudio(a, dir, &log), 0) << log;
    const json r = json::parse(readFile(dir / "r.json"));
    return r.at("frames_drawn").get<int>() - r.at("interactive_from_frame").get<int>();
  };
  const int idle = frames(false), busy = frames(true);
  std::cout << "frames in 2 s: idle " << idle << ", while a job runs " << busy << "\n";
  // 2 s at one frame per half second, the report's frames after it.
  EXPECT_LE(idle, 8);
  EXPECT_GE(idle, 1);
  // At most one frame per 100 ms (and a few more to settle).
  EXPECT_LE(busy, 26);
  EXPECT_GT(busy, idle);
}

TEST(Studio, SaysClearlyWhenThereIsNoDisplay) {
  const auto dir = tempDir("ui_studio_nodisplay");
  const std::string cmd =
      "env -u DISPLAY -u WAYLAND_DISPLAY " BTF_STUDIO " > " + (dir / "log").string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 1);
  const std::string log = readFile(dir / "log");
  EXPECT_NE(log.find("no display"), std::string::npos) << log;
  EXPECT_NE(log.find("xvfb-run"), std::string::npos) << log;
}

TEST(Studio, ScriptErrorsNameTheActionAndExitNonZero) {
  const auto dir = tempDir("ui_studio_badscript");
  json a = json::array({{{"open", sceneFile("brick")}}, {{"teleport", true}}});
  std::string log;
  EXPECT_EQ(runStudio(a, dir, &log), 1);
  EXPECT_NE(log.find("action 2"), std::string::npos) << log;
  EXPECT_NE(log.find("unknown action"), std::string::npos) << log;
  json b = json::array({{{"open", (dir / "missing.json").string()}}});
  EXPECT_EQ(runStudio(b, dir, &log), 1);
  EXPECT_NE(log.find("missing.json"), std::string::npos) << log;
  // A codec option the compress command does not declare, and one out of its range.
  json c = json::array({{{"codec_options", {{"neural_stepz", 300}}}}});
  EXPECT_EQ(runStudio(c, dir, &log), 1);
  EXPECT_NE(log.find("'neural_stepz' is not an option of compress"), std::string::npos) << log;
  json d = json::array({{{"codec_options", {{"neural_steps", 0}}}}});
  EXPECT_EQ(runStudio(d, dir, &log), 1);
  EXPECT_NE(log.find("--neural-steps"), std::string::npos) << log;
  // The object panel's render scale outside its slider's range.
  json e = json::array({{{"object", "sphere"}, {"render_scale", 2}}});
  EXPECT_EQ(runStudio(e, dir, &log), 1);
  EXPECT_NE(log.find("action 1: object: render_scale must be in [0.25, 1]"), std::string::npos)
      << log;
  json g = json::array({{{"interactive", -1}}});
  EXPECT_EQ(runStudio(g, dir, &log), 1);
  EXPECT_NE(log.find("action 1: interactive: expected seconds in (0, 600]"), std::string::npos)
      << log;
  json f = json::array({{{"open_compressed", "x.cbtf"}, {"gpu_table_mib", 0}}});
  EXPECT_EQ(runStudio(f, dir, &log), 1);
  EXPECT_NE(log.find("action 1: open_compressed: gpu_table_mib must be a number in [1, 4096]"),
            std::string::npos)
      << log;
}
