// Use cases on BTF files: compress, compare, export, info and slice. Every reader goes through
// openBtf, so each accepts a raw store or a compressed file alike.
#include <btf/compress/compress.h>
#include <btf/compress/export.h>
#include <btf/compress/lookup.h>
#include <btf/compress/mip.h>
#include <btf/core/parallel.h>
#include <btf/core/progress.h>
#include <btf/core/rng.h>
#include <btf/core/sysinfo.h>
#include <btf/directions/direction_set.h>
#include <btf/io/image_io.h>
#include <btf/ops/internal.h>
#include <btf/render/renderer.h>
#include <btf/store/btf_store.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

namespace btf::ops::detail {

void warnTarget(const Call& c, const CompressedBtf& b) {
  const json params = json::parse(b.paramsJson), stats = json::parse(b.statsJson);
  if (stats.contains("ratio_limit") && stats["ratio_limit"].is_string())
    c.warn(format("ratio 1:%.0f instead of the 1:%g asked: %s", b.ratio(),
                  params.value("target_ratio", 0.0),
                  stats["ratio_limit"].get<std::string>().c_str()));
  const double target = params.value("target_ratio", 0.0) > 0  ? 0.0
                        : params.value("target_rmse", 0.0) > 0 ? params.value("target_rmse", 0.0)
                                                               : 0.05;
  if (target <= 0) return;
  const double stage = stats.value("nmf_relative_rmse", stats.value("training_relative_rmse", 0.0));
  if (stage > target * 1.05)
    c.warn(format("the %s stage alone leaves a relative RMSE of %.1f %% (target %.1f %%)%s",
                  b.codec.c_str(), 100 * stage, 100 * target,
                  b.codec == "nmf"      ? ": the per-texel rank cap binds — raise --max-rank"
                  : b.codec == "neural" ? " on the training texels: raise --components (the "
                                          "latent), --hidden or --neural-steps"
                                        : " on the training texels: raise --train-texels"));
}

std::string compressedText(const CompressedBtf& b, double seconds, uint64_t rss) {
  const double raw = double(b.info.texels()) * b.info.nDirs() * b.info.nDirs() * 12.0;
  const double file = double(b.fileBytes()), vmf = double(b.vmfCoded.size());
  const std::string vmfNote =
      b.hasVmf() ? format(" (with its visibility map, %s; 1:%.0f without)",
                          formatBytes(vmf).c_str(), raw / std::max(1.0, file - vmf))
                 : "";
  return format(
      "  codec %s (%s): %s -> %s, ratio 1:%.0f%s, %s, peak memory %s\n  settings %s\n"
      "  stats %s\n",
      b.codec.c_str(), b.colour.c_str(), formatBytes(raw).c_str(), formatBytes(file).c_str(),
      b.ratio(), vmfNote.c_str(), formatSeconds(seconds).c_str(), formatBytes(double(rss)).c_str(),
      b.paramsJson.c_str(), b.statsJson.c_str());
}

namespace {

std::string errorText(const ErrorReport& e) {
  return format(
      "RMSE %.6g (1/sr), relative RMSE %.3f %%, PSNR %.2f dB (peak %.5g), max |error| "
      "%.5g",
      e.rmse, 100 * e.relRmse, e.psnr, e.peak, e.maxAbs);
}

}  // namespace

std::string levelsReport(const PyramidReport& rep, std::vector<LevelFigures>* levels) {
  levels->clear();
  std::string t;
  for (size_t k = 0; k < rep.levels.size(); ++k) {
    const auto& e = rep.levels[k];
    levels->push_back({int(k), e.nu, e.nv, e.relRmse, e.rmse});
    t += format("  level %-2zu %5d x %-5d relative RMSE %.3f %%\n", k, e.nu, e.nv, 100 * e.relRmse);
  }
  return t;
}

CodecFigures codecFigures(const CompressedBtf& b, double rawBytes, uint64_t compressedBytes,
                          double ratio, uint64_t peakMemoryBytes) {
  CodecFigures f;
  f.params = json::parse(b.paramsJson);
  f.stats = json::parse(b.statsJson);
  f.rawBytes = rawBytes;
  f.compressedBytes = compressedBytes;
  f.vmfBytes = b.vmfCoded.size();
  f.ratio = ratio;
  f.peakMemoryBytes = peakMemoryBytes;
  return f;
}

namespace {

// `compress --mip`: one process (a cluster job refuses it in run.cpp's checks).
void compressMip(const Call& c, const CodecSettings& cs) {
  const Request& r = c.r;
  if (c.ctx.processes().distributed())
    throw Error("compress --mip runs on one process: launch it without mpirun/srun");
  PyramidReport rep;
  const CompressedBtf b = compressPyramid(r.s("input"), cs, c.progress(), c.ctx.cancel, &rep);
  c.ctx.check("encoder");
  writeCompressed(r.s("output"), b);
  c.rep.outputs.push_back(r.s("output"));
  warnTarget(c, b);
  const double raw0 = double(b.info.texels()) * b.info.texelBytes();
  const double rawAll = double(pyramidTexels(b.levels)) * b.info.texelBytes();
  CompressResult res;
  res.input = r.s("input");
  res.output = r.s("output");
  res.file = codecFigures(b, raw0, rep.fileBytes, rep.ratio, rep.peakRssBytes);
  res.seconds = rep.seconds;
  res.trainSeconds = rep.trainSeconds;
  res.encodeSeconds = rep.encodeSeconds;
  res.finishSeconds = rep.finishSeconds;
  CompressResult::Pyramid& py = res.pyramid.emplace();
  py.levelSeconds = rep.levelSeconds;
  py.rawBytes = rawAll;
  py.ratio = rawAll / double(std::max<uint64_t>(1, rep.fileBytes));
  c.rep.text = "wrote " + r.s("output") + " (a pyramid of " + std::to_string(b.levels.size()) +
               " texel levels)\n" + compressedText(b, rep.seconds, rep.peakRssBytes) +
               format(
                   "  pyramid: raw %s (%.3f× level 0) -> 1:%.0f of the pyramid's raw "
                   "bytes; levels built in %s\n",
                   formatBytes(rawAll).c_str(), rawAll / raw0, py.ratio,
                   formatSeconds(rep.levelSeconds).c_str()) +
               levelsReport(rep, &py.levels);
  c.rep.result = res;
  c.rep.summary =
      format("wrote %s, %zu levels, ratio 1:%.0f (of level 0) in %s, level 0 relative RMSE %.2f %%",
             r.s("output").c_str(), b.levels.size(), b.ratio(), formatSeconds(rep.seconds).c_str(),
             100 * rep.levels[0].relRmse);
}

}  // namespace

void compress(const Call& c) {
  const Request& r = c.r;
  CodecSettings cs = codecSettings(r, r.s("codec"));
  cs.memoryBudget = parseBytes(r.s("memory_budget"));
  if (r.b("mip")) {
    compressMip(c, cs);
    return;
  }
  CompressReport rep;
  Comm& comm = c.ctx.processes();
  const CompressedBtf b = compressStore(r.s("input"), cs, c.progress(), c.ctx.cancel, &rep, &comm);
  CompressResult res;
  if (comm.distributed()) {
    res.cluster = clusterFigures(comm, double(rep.texelsEncoded), rep.texelBytes, rep.commBytes,
                                 rep.encodeSeconds);
    if (!comm.root()) return;  // rank 0 writes and reports
  }
  c.ctx.check("encoder");
  writeCompressed(r.s("output"), b);
  c.rep.outputs.push_back(r.s("output"));
  warnTarget(c, b);
  res.input = r.s("input");
  res.output = r.s("output");
  res.file = codecFigures(b, double(b.info.texels()) * b.info.nDirs() * b.info.nDirs() * 12.0,
                          rep.fileBytes, rep.ratio, rep.peakRssBytes);
  res.seconds = rep.seconds;
  res.trainSeconds = rep.trainSeconds;
  res.encodeSeconds = rep.encodeSeconds;
  res.finishSeconds = rep.finishSeconds;
  c.rep.text = "wrote " + r.s("output") + "\n" + compressedText(b, rep.seconds, rep.peakRssBytes) +
               (res.cluster ? clusterText(*res.cluster) : std::string());
  c.rep.summary = format("wrote %s, ratio 1:%.0f in %s", r.s("output").c_str(), b.ratio(),
                         formatSeconds(rep.seconds).c_str());
  if (r.b("compare")) {
    const auto ref = openBtf(r.s("input"));
    const auto dec = makeDecoder(b);
    const ErrorReport e = compareBtfs(*ref, *dec, c.progress(), 10, c.ctx.cancel);
    res.error = e;
    c.rep.text += "  error: " + errorText(e) + "\n";
    c.rep.summary += format(", relative RMSE %.2f %%", 100 * e.relRmse);
  }
  c.rep.result = std::move(res);
}

void compare(const Call& c) {
  const Request& r = c.r;
  Comm& comm = c.ctx.processes();
  std::unique_ptr<Decoder> A, B;
  const int level = r.i("level");
  const uint64_t budget = parseBytes(r.s("memory_budget"));
  collectively(comm, [&] {
    A = openBtfLevel(r.s("a"), level, budget, c.progress(), c.ctx.cancel);
    B = openBtfLevel(r.s("b"), level, budget, c.progress(), c.ctx.cancel);
  });
  // B at A's directions when the sets differ: B's own continuous decode (neural) or its
  // interpolation between its set directions — the error between set directions.
  std::string resampled;
  if (A->info().dirsDeg != B->info().dirsDeg) {
    resampled = B->continuous() ? "continuous" : "interpolated";
    B = atDirections(std::shared_ptr<const Decoder>(std::move(B)), A->info());
  }
  const ErrorReport e = compareBtfs(*A, *B, c.progress(), r.i("worst"), c.ctx.cancel, &comm);
  if (!r.s("maps").empty() && comm.root()) writeErrorMaps(e, r.s("maps"));
  auto ratioOf = [](const std::string& p) {
    return isCompressedFile(p) ? readCompressed(p).ratio() : 1.0;
  };
  const double ratioA = ratioOf(r.s("a")), ratioB = ratioOf(r.s("b"));
  CompareResult res;
  res.error = e;
  res.level = level;
  res.a = {r.s("a"), A->kind(), ratioA};
  res.b = {r.s("b"), B->kind(), ratioB};
  res.maps = r.s("maps");
  res.bAtADirections = resampled;
  std::string t = format("A %s (%s, ratio 1:%.0f)\nB %s (%s, ratio 1:%.0f)\n", r.s("a").c_str(),
                         A->kind().c_str(), ratioA, r.s("b").c_str(), B->kind().c_str(), ratioB);
  if (!resampled.empty())
    t += format("B evaluated at A's %d directions (%s): %s\n", A->info().nDirs(),
                A->info().directionSet.c_str(),
                resampled == "continuous" ? "its own continuous decode"
                                          : "interpolated between its set directions");
  if (level > 0) t += format("texel level %d: %d x %d texels\n", level, A->info().nu, A->info().nv);
  t += errorText(e) + "\n";
  if (!r.s("noise").empty()) {
    // Two independent simulations differ by √2 × the noise of one: that is A's own floor. B's
    // error in excess of it adds in quadrature (independent errors).
    std::unique_ptr<Decoder> N;
    collectively(comm, [&] { N = openBtfLevel(r.s("noise"), level, budget, false, c.ctx.cancel); });
    const ErrorReport f = compareBtfs(*A, *N, c.progress(), 0, c.ctx.cancel, &comm);
    const double floorRmse = f.rmse / std::sqrt(2.0), floorRel = f.relRmse / std::sqrt(2.0);
    const double excessRel = std::sqrt(std::max(0.0, e.relRmse * e.relRmse - floorRel * floorRel));
    res.noise = CompareResult::Noise{r.s("noise"), floorRmse, floorRel, excessRel};
    t += format(
        "noise floor of A (RMS(A − %s)/√2): RMSE %.6g, relative %.3f %%; B's error in "
        "excess of it: relative %.3f %%%s\n",
        r.s("noise").c_str(), floorRmse, 100 * floorRel, 100 * excessRel,
        e.relRmse < 2 * floorRel ? " — the reference is too noisy to judge B: simulate it "
                                   "with more samples"
                                 : "");
  }
  t += "worst texels (u, v: RMSE):";
  for (const auto& w : e.worstTexels)
    t += format(" (%lld, %lld: %.4g)", (long long)(w.index % e.nu), (long long)(w.index / e.nu),
                w.rmse);
  t += "\nworst directions (view θ,φ / light θ,φ: RMSE):";
  const auto& dirs = A->info().dirsDeg;
  for (const auto& w : e.worstDirections) {
    const auto& v = dirs[size_t(w.index / e.nDirs)];
    const auto& l = dirs[size_t(w.index % e.nDirs)];
    t += format(" (%.1f,%.1f / %.1f,%.1f: %.4g)", v[0], v[1], l[0], l[1], w.rmse);
  }
  t += "\n";
  if (!r.s("maps").empty())
    t += "maps: " + r.s("maps") + "/texel_rmse.{exr,png}, " + r.s("maps") +
         "/direction_rmse.{exr,png}\n";
  c.rep.text = t;
  c.rep.summary = format("relative RMSE %.3f %%, PSNR %.2f dB", 100 * e.relRmse, e.psnr);
  c.rep.result = std::move(res);
}

void exportBtf(const Call& c) {
  const Request& r = c.r;
  const auto d = openBtfLevel(r.s("input"), r.i("level"), parseBytes(r.s("memory_budget")),
                              c.progress(), c.ctx.cancel);
  const std::string& fmt = r.s("format");
  const std::string& out = r.s("output");
  ExportResult res;
  res.input = r.s("input");
  res.format = fmt;
  res.output = out;
  res.level = r.i("level");
  c.rep.outputs.push_back(out);
  if (fmt == "ubo2003") {
    Ubo2003Options o;
    o.imageFormat = r.s("image_format");
    o.zip = r.b("zip");
    o.scale = r.f("scale");
    const Ubo2003Report e = exportUbo2003(*d, out, c.progress(), c.ctx.cancel, o);
    ExportResult::Ubo2003 x;
    x.images = e.images;
    x.imageFormat = o.imageFormat;
    x.zip = o.zip;
    if (o.imageFormat != "exr") {
      x.scale = e.scale;
      x.clippedFraction = e.clipped;
    }
    res.details = x;
    c.rep.text = format("wrote %lld %s images and btf_export.json %s %s\n", (long long)e.images,
                        o.imageFormat.c_str(), o.zip ? "into" : "under", out.c_str());
    if (o.imageFormat != "exr")
      c.rep.text += format("8-bit sRGB of aBRDF × %.6g (%s); %.3f %% of the values clipped at 1\n",
                           e.scale, r.f("scale") > 0 ? "--scale" : "1 / peak", 100 * e.clipped);
  } else if (fmt == "ubo2014") {
    const double target = r.f("target_rmse");
    const Ubo2014Report e =
        exportUbo2014(*d, out, r.i("components"), c.progress(), c.ctx.cancel, target);
    res.details = ExportResult::Ubo2014{
        e.bytes, {e.components[0], e.components[1], e.components[2]}, e.relRmse, e.measuredRmse};
    c.rep.text = format(
        "wrote %s (%s): DFMF, colour model 0, fp16, components R %d G %d B %d; the export "
        "adds a relative RMSE of %.3f %% to its input (every texel; training fit %.3f %%)\n",
        out.c_str(), formatBytes(double(e.bytes)).c_str(), e.components[0], e.components[1],
        e.components[2], 100 * e.measuredRmse, 100 * e.relRmse);
    if (r.i("components") == 0 && e.measuredRmse > 1.5 * target)
      c.warn(
          format("the export's error (%.2f %%) exceeds --target-rmse %.2f %%: the training "
                 "texels' spectra underestimate it; give --components",
                 100 * e.measuredRmse, 100 * target));
  } else if (fmt == "rgl-bsdf") {
    // The NDF and projected area from the tile's own facets (the file's scene, rebuilt).
    const BtfTile tile = tileOfBtf(d->info(), r.s("input"), parseBytes(r.s("memory_budget")));
    const TileGeometry& g = tile.geometry;
    std::vector<std::array<double, 3>> areaNormals(g.triangleCount());
    for (size_t t = 0; t < g.triangleCount(); ++t) {
      const Vec3 n = g.faceNormal(uint32_t(t));
      areaNormals[t] = {0.5 * n.x, 0.5 * n.y, 0.5 * n.z};
    }
    RglOptions o;
    o.resolution = r.i("resolution");
    const RglReport e =
        exportRglBsdf(*d, areaNormals, g.Lx * g.Ly, out,
                      "BTF Studio tile-averaged aBRDF of " + r.s("input") + " (scene " +
                          d->info().sceneName + ", level " + std::to_string(r.i("level")) + ")",
                      c.ctx.cancel, o);
    res.details = ExportResult::Rgl{e.bytes, e.thetaI, e.phiI, e.resolution, e.ndfProjectedArea};
    c.rep.text = format(
        "wrote %s (%s): RGL measured BSDF, %d x %d view directions, %d² half vectors, NDF "
        "from %.0f upward facets (projected area %.4f)\n",
        out.c_str(), formatBytes(double(e.bytes)).c_str(), e.thetaI, e.phiI, e.resolution, e.facets,
        e.ndfProjectedArea);
  } else {
    const MerlReport e = exportMerl(*d, out, r.i("phi_samples"), c.progress(), c.ctx.cancel);
    res.details =
        ExportResult::Merl{e.bins, e.missingBins, e.anisotropy, e.asymmetry, e.asymmetryMax};
    c.rep.text = format(
        "wrote %s: 90x90x180 bins, %lld missing (below the horizon), φh spread "
        "%.1f %%, symmetrised f(ωi, ωo) and f(ωo, ωi) (source asymmetry %.2f %% mean, %.1f %% "
        "worst bin)\n",
        out.c_str(), (long long)e.missingBins, 100 * e.anisotropy, 100 * e.asymmetry,
        100 * e.asymmetryMax);
    if (e.asymmetry > 0.01)
      c.warn(
          format("the source violates reciprocity by %.1f %% on average (%.0f %% in the worst "
                 "bin); the export averages f(ωi, ωo) and f(ωo, ωi) — more samples per "
                 "texel (--spp, --max-spp) lower it",
                 100 * e.asymmetry, 100 * e.asymmetryMax));
    if (e.anisotropy > 0.1)
      c.warn(
          format("the texel-averaged aBRDF varies by %.0f %% over the half-vector azimuth; "
                 "MERL is isotropic, so the export averages it away",
                 100 * e.anisotropy));
  }
  c.rep.summary = "wrote " + out;
  c.rep.result = std::move(res);
}

namespace {

// The keys both kinds of file report first, in the same shape.
InfoResult header(const std::string& path, const char* format, const BtfInfo& I) {
  InfoResult j;
  j.path = path;
  j.format = format;
  j.scene = I.sceneName;
  j.sceneHash = I.sceneHash;
  j.nu = I.nu, j.nv = I.nv;
  j.directionSet = I.directionSet;
  j.directionCount = I.nDirs();
  j.directionsDeg = I.dirsDeg;
  return j;
}

json parsedOrString(const std::string& s) {
  if (s.empty()) return json::object();
  try {
    return json::parse(s);
  } catch (const std::exception&) {
    return s;
  }
}

}  // namespace

void info(const Call& c) {
  const std::string& path = c.r.s("btf");
  if (isCompressedFile(path)) {
    CompressedBtf b = readCompressed(path);  // verifies every checksum or throws
    const BtfInfo& I = b.info;
    InfoResult res = header(path, "compressed", I);
    res.fileBytes = b.fileBytes();
    res.verified = true;
    InfoResult::Compressed& j = res.details.emplace<InfoResult::Compressed>();
    j.codec = b.codec;
    j.colour = b.colour;
    j.params = json::parse(b.paramsJson);
    j.stats = json::parse(b.statsJson);
    j.ratio = b.ratio();
    for (const auto& x : b.arrays)
      j.arrays.push_back({x.name, x.rows, x.cols, x.type == ArrayType::F16 ? "f16" : "f32"});
    std::string t = format("%s: compressed BTF, codec %s (%s), %s, ratio 1:%.0f\n", path.c_str(),
                           b.codec.c_str(), b.colour.c_str(),
                           formatBytes(double(b.fileBytes())).c_str(), b.ratio());
    t += format("  scene        %s (hash %s)\n  texels       %d x %d\n  directions   %s (%d)\n",
                I.sceneName.c_str(), I.sceneHash.c_str(), I.nu, I.nv, I.directionSet.c_str(),
                I.nDirs());
    t += "  params       " + b.paramsJson + "\n  stats        " + b.statsJson + "\n";
    if (!b.levels.empty()) {
      // A pyramid: its levels, with the error compress measured for each.
      const json st = json::parse(b.statsJson);
      const json errs = st.contains("levels") ? st["levels"] : json::array();
      for (size_t k = 0; k < b.levels.size(); ++k) {
        const MipLevel& l = b.levels[k];
        const double e =
            k < errs.size() && errs[k].is_object() ? errs[k].value("relative_rmse", -1.0) : -1.0;
        j.levels.push_back({l.nu, l.nv, l.first, e >= 0 ? std::optional<double>(e) : std::nullopt});
        t += format("  level %-6zu %d x %d texels from texel %lld%s\n", k, l.nu, l.nv,
                    (long long)l.first,
                    e >= 0 ? format(", relative RMSE %.3f %%", 100 * e).c_str() : "");
      }
    }
    for (const auto& x : b.arrays)
      t += format("  array        %-18s %lld x %lld %s\n", x.name.c_str(), (long long)x.rows,
                  (long long)x.cols, x.type == ArrayType::F16 ? "f16" : "f32");
    t += "  checksums    all verified\n";
    // The codec's own checks (array shapes against the header, lpca's cluster ids): a file
    // whose checksums hold but that no decoder accepts is not "verified".
    const auto dec = makeDecoder(std::move(b));
    t += "  decoder      arrays consistent with the header\n";
    if (c.r.b("bench_decoder")) {
      // One thread, after the decoder's own set-up: value() at random (texel, view, light),
      // and texel() (every value of a texel) in texel order, each for at least half a second.
      using Clock = std::chrono::steady_clock;
      const int n = dec->info().nDirs();  // b (and I) moved into the decoder
      const int64_t T = dec->info().texels();
      Rng rng(7);
      double sink = 0;
      int64_t values = 0;
      auto t0 = Clock::now();
      double secs = 0;
      while (secs < 0.5) {
        for (int k = 0; k < 4096; ++k) {
          const auto v = dec->value(int64_t(rng.next() % uint64_t(T)),
                                    int(rng.next() % uint64_t(n)), int(rng.next() % uint64_t(n)));
          sink += v[0];
        }
        values += 4096;
        secs = std::chrono::duration<double>(Clock::now() - t0).count();
      }
      const double randomRate = double(values) / secs;
      std::vector<float> buf(size_t(n) * n * 3);
      values = 0;
      t0 = Clock::now();
      secs = 0;
      for (int64_t tx = 0; secs < 0.5; tx = (tx + 1) % T) {
        dec->texel(tx, buf.data());
        sink += buf[0];
        values += int64_t(n) * n;
        secs = std::chrono::duration<double>(Clock::now() - t0).count();
      }
      const double texelRate = double(values) / secs;
      j.decoderBench = InfoResult::Compressed::DecoderBench{randomRate, texelRate, sink};
      t += format(
          "  decode       %.2f M random values/s, %.2f M values/s by whole texels (RGB "
          "values, one thread)\n",
          randomRate * 1e-6, texelRate * 1e-6);
    }
    c.rep.text = t;
    c.rep.summary = "verified " + path;
    c.rep.result = std::move(res);
    return;
  }
  BtfReader rd(path);
  const BtfInfo& I = rd.info();
  const auto v = rd.verify();
  const bool ok = v.badChunks.empty() && v.vmfOk;
  InfoResult res = header(path, "raw", I);
  res.fileBytes = rd.layout().totalBytes;
  res.verified = ok;
  res.details = InfoResult::Raw{
      I.Lx,         I.Ly,   I.chunkTexels,          I.chunks(), I.spp,       I.shadows,
      I.shadowBias, I.seed, parsedOrString(I.plan), I.hasVmf,   v.badChunks, v.vmfOk};
  std::string t = format("%s: raw BTF store, %s\n", path.c_str(),
                         formatBytes(double(rd.layout().totalBytes)).c_str());
  t += format("  scene        %s (hash %s)\n  tile         %g x %g\n  texels       %d x %d\n",
              I.sceneName.c_str(), I.sceneHash.c_str(), I.Lx, I.Ly, I.nu, I.nv);
  t += format("  directions   %s (%d, shared by view and light; %lld pairs)\n",
              I.directionSet.c_str(), I.nDirs(), static_cast<long long>(I.nDirs()) * I.nDirs());
  t += format("  settings     spp %d, shadows %s (bias %g), seed %llu\n", I.spp, I.shadows.c_str(),
              I.shadowBias, static_cast<unsigned long long>(I.seed));
  t += "  plan         " + I.plan + "\n";
  t += format("  chunks       %d of %d texel(s)\n", I.chunks(), I.chunkTexels);
  t += std::string("  checksums    ") + (ok ? "all verified\n" : "MISMATCH:");
  if (!ok) {
    for (int k : v.badChunks) t += format(" chunk %d", k);
    if (!v.vmfOk) t += " visibility-map";
    t += "\n";
  }
  c.rep.text = t;
  c.rep.result = std::move(res);
  if (!ok) {
    std::string what;
    for (int k : v.badChunks)
      what += (what.empty() ? "" : ", ") + std::string("chunk ") + std::to_string(k) +
              " checksum mismatch";
    if (!v.vmfOk)
      what += std::string(what.empty() ? "" : ", ") + "visibility-map checksum mismatch";
    throw Error(path + ": corrupted: " + what);
  }
  c.rep.summary = "verified " + path;
}

void slice(const Call& c) {
  const Request& r = c.r;
  const auto d = openBtfLevel(r.s("btf"), r.i("level"), parseBytes(r.s("memory_budget")),
                              c.progress(), c.ctx.cancel);
  const BtfInfo& I = d->info();
  const DirectionSet dirs = DirectionSet::fromName(I.directionSet);
  if (dirs.size() != I.nDirs())
    throw Error(r.s("btf") + ": the direction set of the file does not match its header");
  double tl, pl;
  parseAnglePair(r.s("light"), "--light", &tl, &pl);
  const auto lw = dirs.interpolate(deg2rad(tl), deg2rad(pl));
  const float scale = float(kPi * r.f("exposure"));
  const std::string& view = r.s("view");
  const std::string& texel = r.s("texel");
  const std::string& out = r.s("output");
  if (view.empty() == texel.empty())
    throw Error(
        "slice needs exactly one of --view θ,φ (spatial image) or --texel u,v|avg (hemisphere)");
  const int n = I.nDirs();
  SliceResult res;
  res.input = r.s("btf");
  res.output = out;
  res.light = {tl, pl};
  res.level = r.i("level");
  c.rep.outputs.push_back(out);
  ImageMetadata meta = {{"units", "aBRDF, 1/sr, linear RGB"},
                        {"light_theta_phi_deg", format("%.10g,%.10g", tl, pl)},
                        {"scene", I.sceneName},
                        {"scene_hash", I.sceneHash},
                        {"source", r.s("btf")},
                        {"texel_level", std::to_string(r.i("level"))}};
  if (!view.empty()) {
    double tv, pv;
    parseAnglePair(view, "--view", &tv, &pv);
    const std::vector<float> img =
        spatialSlice(*d, deg2rad(tv), deg2rad(pv), deg2rad(tl), deg2rad(pl), c.ctx.cancel);
    c.ctx.check("slice");
    meta.push_back({"view_theta_phi_deg", format("%.10g,%.10g", tv, pv)});
    writeRgbImage(out, I.nu, I.nv, img, scale, true, meta);
    res.kind = "spatial";
    res.view = {tv, pv};
    res.width = I.nu, res.height = I.nv;
    c.rep.result = res;
    c.rep.text = format("wrote %s: %dx%d texels, view (%g, %g), light (%g, %g) degrees\n",
                        out.c_str(), I.nu, I.nv, tv, pv, tl, pl);
    c.rep.summary = "wrote " + out;
    return;
  }
  // One texel, or every texel (the tile average).
  int64_t one = -1;
  std::string what = "tile average";
  if (texel != "avg") {
    int u = 0, v = 0;
    char comma = 0, extra = 0;
    if (std::sscanf(texel.c_str(), "%d%c%d%c", &u, &comma, &v, &extra) != 3 || comma != ',')
      throw Error("invalid --texel '" + texel + "': expected u,v (texel indices) or avg");
    if (u < 0 || v < 0 || u >= I.nu || v >= I.nv)
      throw Error("invalid --texel '" + texel + "': outside the " + std::to_string(I.nu) + "x" +
                  std::to_string(I.nv) + " texel grid");
    one = int64_t(v) * I.nu + u;
    what = "texel " + texel;
  }
  // Orthographic hemisphere: pixel (x, y) in the unit disk ↦ view with sinθ = r, φ = atan2(y, x);
  // +x to the right, +y up; outside the disk is black.
  const int S = r.i("size");
  std::vector<float> img(size_t(S) * S * 3, 0.f);
  auto pixelView = [S](int i, int jj, double* theta, double* phi) {
    const double x = (i + 0.5) / S * 2 - 1, y = (jj + 0.5) / S * 2 - 1;
    const double rr = std::sqrt(x * x + y * y);
    if (rr > 1) return false;
    *theta = std::asin(std::min(rr, 1.0)), *phi = std::atan2(y, x);
    return true;
  };
  if (d->continuous()) {
    // The decoder's own value at each pixel's view and the light itself (the neural codec), as
    // `slice --view` and the batched lookups read it — not interpolated between set directions.
    const int64_t t0 = one >= 0 ? one : 0, t1 = one >= 0 ? one + 1 : I.texels();
    const double w = 1.0 / double(t1 - t0), tlr = deg2rad(tl), plr = deg2rad(pl);
    ProgressReporter pr("slice", S, c.progress());
    parallelForChunks(
        S, 1,
        [&](int64_t j0, int64_t j1) {
          for (int64_t jj = j0; jj < j1; ++jj) {
            for (int i = 0; i < S; ++i) {
              double th, ph;
              if (!pixelView(i, int(jj), &th, &ph)) continue;
              double acc[3] = {0, 0, 0};
              for (int64_t t = t0; t < t1; ++t) {
                const auto val = d->evaluate(t, tlr, plr, th, ph);
                for (int k = 0; k < 3; ++k) acc[k] += val[size_t(k)];
              }
              for (int k = 0; k < 3; ++k)
                img[(size_t(jj) * S + size_t(i)) * 3 + size_t(k)] = float(acc[k] * w);
            }
            pr.add(1);
          }
        },
        c.ctx.cancel);
    c.ctx.check("slice");
    pr.finish();
  } else {
    // The texel's (or the tile average's) views × lights matrix, reduced to the chosen light,
    // then interpolated between the set's views.
    std::vector<float> perView(size_t(n) * 3, 0.f);
    std::vector<float> m(size_t(n) * n * 3);
    auto accumulate = [&](const float* mm, float w) {
      for (int v = 0; v < n; ++v)
        for (const auto& l : lw)
          for (int k = 0; k < 3; ++k)
            perView[size_t(v) * 3 + size_t(k)] +=
                w * float(l.weight) * mm[(size_t(v) * size_t(n) + size_t(l.index)) * 3 + size_t(k)];
    };
    if (one < 0) {
      const float w = 1.0f / float(I.texels());
      for (int64_t t = 0; t < I.texels(); ++t) {
        if (t % 64 == 0) c.ctx.check("slice");
        d->texel(t, m.data());
        accumulate(m.data(), w);
      }
    } else {
      d->texel(one, m.data());
      accumulate(m.data(), 1.0f);
    }
    for (int jj = 0; jj < S; ++jj)
      for (int i = 0; i < S; ++i) {
        double th, ph;
        if (!pixelView(i, jj, &th, &ph)) continue;
        const auto vw = dirs.interpolate(th, ph);
        for (const auto& v : vw)
          for (int k = 0; k < 3; ++k)
            img[(size_t(jj) * S + size_t(i)) * 3 + size_t(k)] +=
                float(v.weight) * perView[size_t(v.index) * 3 + size_t(k)];
      }
  }
  meta.push_back({"texel", texel});
  writeRgbImage(out, S, S, img, scale, true, meta);
  res.kind = "hemisphere";
  res.texel = texel;
  res.width = res.height = S;
  c.rep.result = res;
  c.rep.text = format("wrote %s: aBRDF over views of the %s, light (%g, %g) degrees\n", out.c_str(),
                      what.c_str(), tl, pl);
  c.rep.summary = "wrote " + out;
}

}  // namespace btf::ops::detail
