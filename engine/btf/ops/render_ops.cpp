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
RenderResult::Image::Footprint footprint(const RenderImage& img) {
  std::vector<float> area;
  std::vector<int64_t> hist;
  for (size_t k = 0; k < img.lod.size(); ++k) {
    if (img.lod[k] < 0) continue;
    area.push_back(img.footprintTexels[k]);
    const size_t l = size_t(std::max(0.f, img.lod[k]) + 0.5f);
    if (hist.size() <= l) hist.resize(l + 1, 0);
    ++hist[l];
  }
  RenderResult::Image::Footprint f;
  f.pixels = area.size();
  if (area.empty()) return f;
  std::nth_element(area.begin(), area.begin() + ptrdiff_t(area.size() / 2), area.end());
  f.medianTexelsPerSample = area[area.size() / 2];
  for (int64_t n : hist) f.levelShare.push_back(double(n) / double(area.size()));
  return f;
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
                       ? "(this .cbtf was written before files carried theirs): compress it "
                         "again, or give the raw store it was compressed from with --vmf FILE.btf"
                       : "(it was simulated with --vmf off): simulate it again with --vmf on"));
  }
  const RenderScene rs(makeObject(r.s("object"), r.i("level")), tile.Lx, tile.Ly, tile.zmin,
                       tile.zmax, s);
  const std::vector<Material> materials = compileMaterials(scene);

  RenderResult res;
  res.input = input;
  res.output = output;
  res.mode = mode;
  res.object = r.s("object");
  res.width = s.width, res.height = s.height;
  res.spp = s.spp;
  res.tiling = s.tiling;
  res.reliefScale = s.reliefScale;
  res.filter = r.s("filter");
  if (btf)
    res.texelLevels = RenderResult::TexelLevels{btf->levels(),
                                                btf->levels() == 1  ? "none"
                                                : btf->fileLevels() ? "file"
                                                                    : "box filtered",
                                                s.forceLevel, s.maxAniso};
  res.camera = {s.camTheta, s.camPhi};
  res.light = {s.lightTheta, s.lightPhi};
  res.irradiance = s.irradiance;
  res.environment = s.environment;
  res.projection = r.s("projection");
  res.worldPerTileUnit = rs.worldPerTile();
  res.prisms = rs.prisms();
  res.shellFaces = rs.shellFaces();
  res.heightRangeWorld = {double(tile.zmin) * rs.heightScale(),
                          double(tile.zmax) * rs.heightScale()};
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
  for (const std::string& m : modes) {
    ProgressReporter pr("render " + m, s.height, c.progress());
    RenderImage img = m == "flat" ? rs.renderFlat(*btf, c.ctx.cancel, &pr)
                      : m == "mapped"
                          ? rs.renderMapped(*btf, c.ctx.cancel, &pr)
                          : rs.renderExact(tile, materials, maxTriangles, c.ctx.cancel, &pr);
    pr.finish();
    RenderResult::Image e;
    e.mode = m;
    e.seconds = img.seconds;
    e.samples = img.samples;
    e.rays = img.rays;
    e.triangles = img.triangles;
    if (m != "exact") e.footprint = footprint(img);
    std::string file = output;
    if (mode == "all") {
      const fs::path o(output);
      file = (o.parent_path() / (o.stem().string() + "." + m + ".exr")).string();
    }
    e.output = file;
    ImageMetadata md = meta;
    md.push_back({"mode", m});
    if (lower(fs::path(file).extension().string()) == ".exr")
      writeRgbaImage(file, img.width, img.height, img.rgb, &img.alpha, 1.f, false, md);
    else
      writeRgbImage(file, img.width, img.height, img.rgb, float(r.f("exposure")), false, md);
    c.rep.outputs.push_back(file);
    if (haveRef) e.error = compareImages(img, ref);
    res.images.push_back(std::move(e));
    images.push_back(std::move(img));
  }
  if (mode == "all") {
    for (size_t k = 1; k < images.size(); ++k)
      res.images[k].errorVsExact = compareImages(images[k], images[0]);
    writeSideBySide(output, {&images[0], &images[1], &images[2]}, float(r.f("exposure")));
    c.rep.outputs.push_back(output);
    res.mappedSpeedup = images[1].seconds > 0 ? images[0].seconds / images[1].seconds : 0.0;
  }
  std::string text;
  for (const auto& e : res.images) {
    text += format("%-6s %8.2f s  %llu samples, %llu rays, %llu triangles -> %s", e.mode.c_str(),
                   e.seconds, (unsigned long long)e.samples, (unsigned long long)e.rays,
                   (unsigned long long)e.triangles, e.output.c_str());
    if (e.error)
      text += format("  [vs reference: rel. RMSE %.2f %%, coverage mismatch %.2f %%]",
                     100 * e.error->relRmse, 100 * e.error->coverageMismatch);
    if (e.errorVsExact)
      text += format("  [vs exact: rel. RMSE %.2f %%, coverage mismatch %.2f %%]",
                     100 * e.errorVsExact->relRmse, 100 * e.errorVsExact->coverageMismatch);
    text += "\n";
  }
  if (mode == "all")
    text += "side by side (exact | mapped | flat | |mapped - exact|): " + output + "\n";
  c.rep.text = text;
  c.rep.summary = "rendered " + output;
  c.rep.result = std::move(res);
}

}  // namespace btf::ops::detail
