// btfsim render (docs/render.md): a BTF on an object in the flat, mapped or exact mode, or all
// three side by side with the mapped and flat images' errors against the exact one.
#include <btf/compress/cbtf.h>
#include <btf/compress/codec.h>
#include <btf/core/sysinfo.h>
#include <btf/geometry/tile_builder.h>
#include <btf/io/image_io.h>
#include <btf/ops/internal.h>
#include <btf/render/renderer.h>
#include <btf/scene/material.h>
#include <btf/store/btf_store.h>

#include <cmath>
#include <filesystem>
#include <memory>

namespace btf::ops::detail {

namespace fs = std::filesystem;

namespace {

std::string lower(std::string s) {
  for (auto& ch : s) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return s;
}

json errorJson(const ImageError& e) {
  json j;
  j["rel_rmse"] = e.relRmse;
  j["rel_rmse_interior"] = e.relRmseInterior;
  j["interior_pixels"] = e.interiorPixels;
  j["coverage_mismatch"] = e.coverageMismatch;
  j["reference_pixels"] = e.refPixels;
  j["mismatch_pixels"] = e.mismatchPixels;
  j["extra_pixels"] = e.extraPixels;
  return j;
}

/// exact | mapped | flat | |mapped − exact| (magenta where one covers the pixel and the other
/// does not), 4-pixel black gaps, tone mapped like the PNGs.
void writeSideBySide(const std::string& path, const std::vector<const RenderImage*>& imgs,
                     float scale) {
  const int w = imgs[0]->width, h = imgs[0]->height, gap = 4;
  const int n = int(imgs.size()) + 1;
  const int W = n * w + (n - 1) * gap;
  std::vector<float> out(size_t(W) * size_t(h) * 3, 0.f);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i) {
        const size_t s = (size_t(j) * size_t(w) + size_t(i)) * 3;
        const size_t d = (size_t(j) * size_t(W) + size_t(k * (w + gap) + i)) * 3;
        const size_t p = size_t(j) * size_t(w) + size_t(i);
        const bool mismatch = (imgs[1]->alpha[p] >= 0.5f) != (imgs[0]->alpha[p] >= 0.5f);
        for (int c = 0; c < 3; ++c)
          out[d + size_t(c)] =
              k < n - 1  ? imgs[size_t(k)]->rgb[s + size_t(c)]
              : mismatch ? (c == 1 ? 0.f : 1.f / scale)  // coverage mismatch: magenta
                         : std::abs(imgs[1]->rgb[s + size_t(c)] - imgs[0]->rgb[s + size_t(c)]);
      }
  writeRgbImage(path, W, h, out, scale, false);
}

// The texel footprints of a flat or mapped image: median area in level-0 texels (of a pixel's
// samples, each a 1/spp share of the pixel) and the share of pixels at each level.
json footprintJson(const RenderImage& img) {
  std::vector<float> area;
  std::vector<int64_t> hist;
  for (size_t k = 0; k < img.lod.size(); ++k) {
    if (img.lod[k] < 0) continue;
    area.push_back(img.footprintTexels[k]);
    const size_t l = size_t(std::max(0.f, img.lod[k]) + 0.5f);
    if (hist.size() <= l) hist.resize(l + 1, 0);
    ++hist[l];
  }
  json j;
  j["pixels"] = area.size();
  if (area.empty()) return j;
  std::nth_element(area.begin(), area.begin() + ptrdiff_t(area.size() / 2), area.end());
  j["median_texels_per_sample"] = area[area.size() / 2];
  json h = json::array();
  for (int64_t n : hist) h.push_back(double(n) / double(area.size()));
  j["level_share"] = h;
  return j;
}

}  // namespace

void render(const Call& c) {
  const Request& r = c.r;
  const std::string input = r.s("input"), output = r.s("output"), mode = r.s("mode");
  const std::string outExt = lower(fs::path(output).extension().string());
  if (mode == "all" && outExt != ".png")
    throw Error("--output: --mode all writes a side-by-side .png (got '" + output + "')");
  if (outExt != ".exr" && outExt != ".png")
    throw Error("--output: expected an .exr or .png image (got '" + output + "')");
  RenderSettings s;
  parseTexels(r.s("size"), &s.width, &s.height, "--size");
  if (s.width < 1 || s.height < 1 || s.width > 16384 || s.height > 16384)
    throw Error("--size: must be 1..16384 pixels a side (got '" + r.s("size") + "')");
  s.spp = r.i("spp");
  parseAnglePair(r.s("camera"), "--camera", &s.camTheta, &s.camPhi, 180);
  parseAnglePair(r.s("light"), "--light", &s.lightTheta, &s.lightPhi, 180);
  s.perspective = r.s("projection") == "perspective";
  s.fovDeg = r.f("fov");
  s.zoom = r.f("zoom");
  s.irradiance = r.f("irradiance");
  s.environment = r.f("environment");
  s.tiling = r.f("tiling");
  s.reliefScale = r.f("relief_scale");
  s.bounces = r.i("bounces");
  s.seed = uint64_t(r.i("seed"));
  s.mip = r.s("filter") == "mip";
  s.forceLevel = r.i("mip_level");
  s.showLevel = r.b("show_level");
  s.maxAniso = r.i("max_aniso");
  if (s.showLevel && mode != "flat" && mode != "mapped")
    throw Error("--show-level draws the texel levels of --mode flat or mapped (got '" + mode +
                "')");
  const uint64_t budget = parseBytes(r.s("memory_budget"));

  // The tile: the BTF's embedded scene, or a scene file (exact only).
  const bool sceneInput = lower(fs::path(input).extension().string()) == ".json";
  if (sceneInput && mode != "exact")
    throw Error(input + ": a scene renders --mode exact only; flat and mapped need a BTF");
  Scene scene;
  std::string sceneHash;
  std::unique_ptr<BtfSampler> btf;
  const bool needBtf = mode != "exact";
  TileGeometry tile;
  bool flatTile = false;
  if (sceneInput) {
    scene = loadScene(input);
    tile = buildTileGeometry(scene, budget);
  } else {
    const BtfInfo info =
        isCompressedFile(input) ? readCompressed(input).info : BtfReader(input).info();
    BtfTile t = tileOfBtf(info, input, budget);
    scene = std::move(t.scene), tile = std::move(t.geometry), flatTile = t.flat;
    sceneHash = info.sceneHash;
  }
  if (needBtf) {
    btf = std::make_unique<BtfSampler>(input, r.s("vmf"), flatTile, budget, c.ctx.cancel,
                                       s.mip || s.forceLevel >= 0);
    if (s.forceLevel >= btf->levels())
      throw Error(format("--mip-level %d: %s has levels 0..%d", s.forceLevel, input.c_str(),
                         btf->levels() - 1));
    if (s.environment > 0) btf->prepareAmbient(c.ctx.cancel);
    if ((mode == "mapped" || mode == "all") && !btf->hasVmf() && !flatTile)
      throw Error(input + " has no visibility map, and the mapped mode needs one for a relief " +
                  (isCompressedFile(input)
                       ? "(a .cbtf holds none): give the raw store it was compressed from "
                         "with --vmf FILE.btf"
                       : "(it was simulated with --vmf off): simulate it again with --vmf on"));
  }
  const RenderScene rs(makeObject(r.s("object"), r.i("level")), tile.Lx, tile.Ly, tile.zmin,
                       tile.zmax, s);
  const std::vector<Material> materials = compileMaterials(scene);

  json& j = c.rep.json;
  j["input"] = input;
  j["output"] = output;
  j["mode"] = mode;
  j["object"] = r.s("object");
  j["size"] = {s.width, s.height};
  j["spp"] = s.spp;
  j["tiling"] = s.tiling;
  j["relief_scale"] = s.reliefScale;
  j["filter"] = r.s("filter");
  if (btf)
    j["texel_levels"] = {{"count", btf->levels()},
                         {"from", btf->levels() == 1  ? "none"
                                  : btf->fileLevels() ? "file"
                                                      : "box filtered"},
                         {"forced", s.forceLevel},
                         {"max_aniso", s.maxAniso}};
  j["camera_theta_phi_deg"] = {s.camTheta, s.camPhi};
  j["light_theta_phi_deg"] = {s.lightTheta, s.lightPhi};
  j["irradiance"] = s.irradiance;
  j["environment"] = s.environment;
  j["projection"] = r.s("projection");
  j["world_per_tile_unit"] = rs.worldPerTile();
  j["shell"] = {{"prisms", rs.prisms()},
                {"faces", rs.shellFaces()},
                {"height_range_world",
                 {double(tile.zmin) * rs.heightScale(), double(tile.zmax) * rs.heightScale()}}};
  std::vector<std::string> modes;
  if (mode == "all")
    modes = {"exact", "mapped", "flat"};
  else
    modes = {mode};
  // Exact's triangles: ~64 bytes each in Embree and our arrays.
  const uint64_t maxTriangles = budget / 96;
  c.notice(
      format("render: %s on %s, %d tiles per uv unit (%.4g world units per tile), %zu "
             "prisms; %dx%d pixels × %d samples%s",
             scene.name.c_str(), r.s("object").c_str(), int(std::lround(s.tiling)),
             rs.worldPerTile() * tile.Lx, rs.prisms(), s.width, s.height, s.spp,
             std::count(modes.begin(), modes.end(), "exact")
                 ? format("; exact: about %llu triangles",
                          (unsigned long long)rs.exactTriangleEstimate(tile))
                       .c_str()
                 : ""));

  RenderImage ref;
  const bool haveRef = !r.s("reference").empty();
  if (haveRef) {
    int w = 0, h = 0;
    ref.rgb = readRgbImage(r.s("reference"), &w, &h, &ref.alpha);
    ref.width = w, ref.height = h;
    // A damaged reference never puts a NaN into the report.
    for (float& v : ref.rgb)
      if (!std::isfinite(v)) v = 0;
    for (float& a : ref.alpha) a = std::isfinite(a) ? std::clamp(a, 0.f, 1.f) : 0.f;
    if (w != s.width || h != s.height)
      throw Error(format("--reference: %s is %dx%d, the render is %dx%d", r.s("reference").c_str(),
                         w, h, s.width, s.height));
  }
  std::vector<RenderImage> images;
  const ImageMetadata meta = {{"units", "radiance, linear RGB; alpha: coverage"},
                              {"scene", scene.name},
                              {"scene_hash", sceneHash},
                              {"object", r.s("object")},
                              {"source", input}};
  json list = json::array();
  for (const std::string& m : modes) {
    ProgressReporter pr("render " + m, s.height, c.progress());
    RenderImage img = m == "flat" ? rs.renderFlat(*btf, c.ctx.cancel, &pr)
                      : m == "mapped"
                          ? rs.renderMapped(*btf, c.ctx.cancel, &pr)
                          : rs.renderExact(tile, materials, maxTriangles, c.ctx.cancel, &pr);
    pr.finish();
    json e;
    e["mode"] = m;
    e["seconds"] = img.seconds;
    e["samples"] = img.samples;
    e["rays"] = img.rays;
    e["triangles"] = img.triangles;
    e["samples_per_second"] = img.seconds > 0 ? double(img.samples) / img.seconds : 0.0;
    if (m != "exact") e["footprint"] = footprintJson(img);
    std::string file = output;
    if (mode == "all") {
      const fs::path o(output);
      file = (o.parent_path() / (o.stem().string() + "." + m + ".exr")).string();
    }
    e["output"] = file;
    ImageMetadata md = meta;
    md.push_back({"mode", m});
    if (lower(fs::path(file).extension().string()) == ".exr")
      writeRgbaImage(file, img.width, img.height, img.rgb, &img.alpha, 1.f, false, md);
    else
      writeRgbImage(file, img.width, img.height, img.rgb, float(r.f("exposure")), false, md);
    c.rep.outputs.push_back(file);
    if (haveRef) e["error"] = errorJson(compareImages(img, ref));
    list.push_back(e);
    images.push_back(std::move(img));
  }
  if (mode == "all") {
    for (size_t k = 1; k < images.size(); ++k)
      list[k]["error_vs_exact"] = errorJson(compareImages(images[k], images[0]));
    writeSideBySide(output, {&images[0], &images[1], &images[2]}, float(r.f("exposure")));
    c.rep.outputs.push_back(output);
    j["mapped_speedup"] = images[1].seconds > 0 ? images[0].seconds / images[1].seconds : 0.0;
  }
  j["images"] = list;
  std::string text;
  for (const auto& e : list) {
    text += format("%-6s %8.2f s  %llu samples, %llu rays, %llu triangles -> %s",
                   e["mode"].get<std::string>().c_str(), e["seconds"].get<double>(),
                   (unsigned long long)e["samples"].get<uint64_t>(),
                   (unsigned long long)e["rays"].get<uint64_t>(),
                   (unsigned long long)e["triangles"].get<uint64_t>(),
                   e["output"].get<std::string>().c_str());
    for (const char* key : {"error", "error_vs_exact"})
      if (e.contains(key))
        text += format("  [%s: rel. RMSE %.2f %%, coverage mismatch %.2f %%]",
                       std::string(key) == "error" ? "vs reference" : "vs exact",
                       100 * e[key]["rel_rmse"].get<double>(),
                       100 * e[key]["coverage_mismatch"].get<double>());
    text += "\n";
  }
  if (mode == "all")
    text += "side by side (exact | mapped | flat | |mapped - exact|): " + output + "\n";
  c.rep.text = text;
  c.rep.summary = "rendered " + output;
}

}  // namespace btf::ops::detail
