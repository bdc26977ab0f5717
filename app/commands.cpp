#include "commands.h"

#include <btf/compress/compress.h>
#include <btf/compress/export.h>
#include <btf/core/error.h>
#include <btf/core/parallel.h>
#include <btf/core/sysinfo.h>
#include <btf/io/image_io.h>
#include <btf/scene/scene.h>
#include <btf/sim/brdf_probe.h>
#include <btf/sim/path_tracer.h>
#include <btf/sim/simulator.h>
#include <btf/sim/study.h>
#include <btf/store/btf_store.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace btf::cli {

using json = nlohmann::ordered_json;

void parseTexels(const std::string& s, int* nu, int* nv) {
  int a = 0, b = 0;
  char x = 0, extra = 0;
  const int n = std::sscanf(s.c_str(), "%d%c%d%c", &a, &x, &b, &extra);
  if (n == 1)
    b = a;
  else if (!(n == 3 && (x == 'x' || x == 'X')))
    throw Error("invalid --texels '" + s + "': expected N or NUxNV, e.g. 64 or 64x32");
  if (a < 1 || b < 1 || a > 16384 || b > 16384)
    throw Error("invalid --texels '" + s + "': each count must be between 1 and 16384");
  *nu = a;
  *nv = b;
}

void parseAnglePair(const std::string& s, const std::string& what, double* theta, double* phi) {
  std::istringstream in(s);
  char comma = 0;
  std::string rest;
  if (!(in >> *theta >> comma >> *phi) || comma != ',' || (in >> rest))
    throw Error("invalid " + what + " '" + s + "': expected θ,φ in degrees, e.g. 30,45");
  if (!std::isfinite(*theta) || !std::isfinite(*phi) || *theta < 0 || *theta >= 90)
    throw Error("invalid " + what + " '" + s + "': θ must be in [0, 90) degrees");
}

SimOptions sceneOptions(const Scene& scene, const std::string& texels, const std::string& dirs,
                        int spp, const std::string& shadows) {
  SimOptions o = optionsFromScene(scene);
  if (!texels.empty()) parseTexels(texels, &o.nu, &o.nv);
  if (!dirs.empty()) o.directions = dirs;
  if (spp != 0) o.spp = spp;
  if (!shadows.empty()) o.shadows = parseShadowMode(shadows);
  return o;
}

void applyEffects(const EffectArgs& e, SimOptions* o) {
  // The scene's simulation block gave the defaults; options given here override them.
  if (!e.method.empty()) o->method = e.method;
  o->plan.selfShadowing = parseToggle(e.selfShadowing, "--self-shadowing");
  if (!e.interreflection.empty())
    o->plan.interreflection = parseToggle(e.interreflection, "--interreflection");
  o->plan.colour = parseToggle(e.colour, "--colour");
  o->plan.glossyIndirect = parseToggle(e.glossyIndirect, "--glossy-indirect");
  o->plan.vmf = parseToggle(e.vmf, "--vmf");
  if (e.bounces < 0 || e.bounces > 64) throw Error("invalid --bounces: must be 1..64 (0 = plan)");
  if (e.bounces > 0) {
    o->plan.bounces = e.bounces;
    if (e.bounces > 1 && o->plan.interreflection == Toggle::Auto)
      o->plan.interreflection = Toggle::On;
    if (e.bounces == 1) o->plan.interreflection = Toggle::Off;
  }
  if (!(e.epsilon > 0 && e.epsilon < 1)) throw Error("invalid --epsilon: must be in (0, 1)");
  o->plan.epsilon = e.epsilon;
  if (e.networkVoxels != 0 && (e.networkVoxels < 2 || e.networkVoxels > 1024))
    throw Error("invalid --network-voxels: must be 2..1024 (0 = one per texel)");
  if (e.networkVoxels != 0) o->network.voxels = e.networkVoxels;
  o->network.links = e.links;
  o->network.gather = e.gather;
  o->ptPaths = e.paths;
}

namespace {

void printPlan(const EffectPlan& p, FILE* out) {
  for (const auto& d : p.decisions)
    std::fprintf(out, "  %-16s %-4s %s%s%s\n", d.effect.c_str(), d.value.c_str(),
                 d.forced ? "[forced] " : "", d.reason.c_str(),
                 d.secondsSaved > 0 ? (" — saves ~" + formatSeconds(d.secondsSaved)).c_str() : "");
}

void printEstimate(const SimEstimate& e, const SimOptions& o) {
  std::fprintf(
      stderr,
      "estimate: %s (hit maps %s, aBRDF %s) on %d thread(s); memory %s of a %s budget; "
      "disk %s (%s free); %d chunk(s) of %d texel(s)\n",
      formatSeconds(e.seconds).c_str(), formatSeconds(e.hitMapSeconds).c_str(),
      formatSeconds(e.evalSeconds).c_str(), e.threads, formatBytes(double(e.memoryBytes)).c_str(),
      formatBytes(double(o.memoryBudget)).c_str(), formatBytes(double(e.diskBytes)).c_str(),
      e.freeDiskBytes ? formatBytes(double(e.freeDiskBytes)).c_str() : "?", e.chunks,
      e.chunkTexels);
}

CodecSettings codecSettings(const CodecArgs& a) {
  CodecSettings s;
  s.codec = a.codec;
  s.colour = a.colourModel;
  s.components = a.components;
  s.targetRmse = a.targetRmse;
  s.targetRatio = a.targetRatio;
  s.beta = a.beta;
  s.betaMode = la::betaModeFromName(a.betaMode);
  s.solver = la::nmfSolverFromName(a.solver);
  s.maxRank = a.maxRank;
  s.nmfIterations = a.iterations;
  s.trainTexels = a.trainTexels;
  s.clusters = a.clusters;
  s.half = !a.f32;
  validate(s);
  return s;
}

// Says when a codec's own stage already exceeds the error target (the target only steers).
void warnTarget(const CompressedBtf& c) {
  const json params = json::parse(c.paramsJson), stats = json::parse(c.statsJson);
  const double target = params.value("target_ratio", 0.0) > 0  ? 0.0
                        : params.value("target_rmse", 0.0) > 0 ? params.value("target_rmse", 0.0)
                                                               : 0.05;
  if (target <= 0) return;
  const double stage = stats.value("nmf_relative_rmse", stats.value("training_relative_rmse", 0.0));
  if (stage > target * 1.05)
    std::fprintf(stderr,
                 "btfsim: warning: the %s stage alone leaves a relative RMSE of %.1f %% (target "
                 "%.1f %%)%s\n",
                 c.codec.c_str(), 100 * stage, 100 * target,
                 c.codec == "nmf" ? ": the per-texel rank cap binds — raise --max-rank"
                                  : " on the training texels: raise --train-texels");
}

void printCompressed(const CompressedBtf& c, double seconds, uint64_t rss) {
  warnTarget(c);
  const double raw = double(c.info.texels()) * c.info.nDirs() * c.info.nDirs() * 12.0;
  std::printf("  codec %s (%s): %s -> %s, ratio 1:%.0f, %s, peak memory %s\n", c.codec.c_str(),
              c.colour.c_str(), formatBytes(raw).c_str(),
              formatBytes(double(c.fileBytes())).c_str(), c.ratio(), formatSeconds(seconds).c_str(),
              formatBytes(double(rss)).c_str());
  std::printf("  settings %s\n  stats %s\n", c.paramsJson.c_str(), c.statsJson.c_str());
}

int simulateCompressed(const SimulateArgs& a, SimulationJob& job, const SimEstimate& est,
                       const SimOptions& o) {
  CodecArgs ca = a.codec;
  ca.codec = a.compress;
  const CodecSettings cs = codecSettings(ca);
  const BtfInfo info = job.storeInfo(est.chunkTexels);
  auto enc = makeEncoder(cs, info);
  const double need = double(est.memoryBytes) + double(enc->memoryBytes()) +
                      double(enc->trainingTexels().size()) * double(info.texelBytes());
  if (need > double(o.memoryBudget))
    throw Error("refusing to start: simulating and compressing needs about " + formatBytes(need) +
                " (simulation " + formatBytes(double(est.memoryBytes)) + ", encoder " +
                formatBytes(double(enc->memoryBytes())) + ", training texels " +
                formatBytes(double(enc->trainingTexels().size()) * double(info.texelBytes())) +
                ") but --memory-budget is " + formatBytes(double(o.memoryBudget)));
  std::fprintf(stderr,
               "streaming into codec %s: no raw BTF is written (raw size would be %s); encoder "
               "memory about %s\n",
               cs.codec.c_str(), formatBytes(double(btfFileBytes(info))).c_str(),
               formatBytes(double(enc->memoryBytes())).c_str());
  const auto train = enc->trainingTexels();
  job.setTrainingTexels(train, [&](const float* v) { enc->train(v); });
  double encodeSeconds = 0;
  job.setChunkSink([&](int, int64_t t0, int64_t t1, const float* values) {
    const auto s0 = std::chrono::steady_clock::now();
    enc->add(t0, t1, values);
    encodeSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count();
  });
  const auto start = std::chrono::steady_clock::now();
  const SimReport r = job.run("", est);
  if (r.cancelled) throw Error("simulation cancelled");
  const auto f0 = std::chrono::steady_clock::now();
  const CompressedBtf c = enc->finish();
  const double finishSeconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - f0).count();
  writeCompressed(a.output, c);
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const uint64_t rss = peakRssBytes();
  if (a.json) {
    json j;
    j["output"] = a.output;
    j["scene"] = job.scene().name;
    j["texels"] = {o.nu, o.nv};
    j["directions"] = job.directions().name();
    j["codec"] = json::parse(c.paramsJson);
    j["stats"] = json::parse(c.statsJson);
    j["wall_seconds"] = wall;
    j["simulate_seconds"] = r.wallSeconds - encodeSeconds;
    j["encode_seconds"] = encodeSeconds;
    j["finish_seconds"] = finishSeconds;
    j["raw_bytes"] = double(info.texels()) * info.nDirs() * info.nDirs() * 12.0;
    j["compressed_bytes"] = c.fileBytes();
    j["ratio"] = c.ratio();
    j["peak_memory_bytes"] = rss;
    std::cout << j.dump(2) << std::endl;
  } else {
    std::printf("wrote %s\n", a.output.c_str());
    std::printf(
        "  %d x %d texels, %d directions (%s); wall %s: simulation %s, encoding %s, "
        "finish (PCA) %s\n",
        o.nu, o.nv, job.directions().size(), job.directions().name().c_str(),
        formatSeconds(wall).c_str(), formatSeconds(r.wallSeconds - encodeSeconds).c_str(),
        formatSeconds(encodeSeconds).c_str(), formatSeconds(finishSeconds).c_str());
    printCompressed(c, wall, rss);
  }
  return 0;
}

}  // namespace

int simulate(const SimulateArgs& a) {
  const Scene scene = loadScene(a.scene);
  SimOptions o = sceneOptions(scene, a.texels, a.dirs, a.spp, a.shadows);
  if (a.seed >= 0) o.seed = uint64_t(a.seed);
  if (a.threads < 0) throw Error("invalid --threads: must be >= 0");
  applyEffects(a.effects, &o);
  o.shadowBias = float(a.bias);
  o.memoryBudget = parseBytes(a.memoryBudget);
  if (a.chunkTexels < 0) throw Error("invalid --chunk-texels: must be >= 0");
  o.maxChunkTexels = a.chunkTexels;
  o.resume = a.resume;
  o.progress = !a.quiet;
  ThreadLimit limit(a.threads);
  SimulationJob job(scene, o);
  const SimEstimate est = job.estimate(a.compress.empty() ? a.output : std::string());
  if (!a.quiet) {
    std::fprintf(stderr, "effect plan (%s):\n", o.method.c_str());
    printPlan(job.plan(), stderr);
  }
  printEstimate(est, o);
  if (!est.refusal.empty()) throw Error("refusing to start: " + est.refusal);
  if (!a.compress.empty()) return simulateCompressed(a, job, est, o);
  const SimReport r = job.run(a.output, est);
  const double evalRate = r.evalSeconds > 0 ? double(r.abrdfValues) / r.evalSeconds : 0;
  const double rayRate = r.hitMapSeconds > 0 ? double(r.hitMapRays) / r.hitMapSeconds : 0;
  if (a.json) {
    json j;
    j["output"] = r.output;
    j["scene"] = scene.name;
    j["texels"] = {o.nu, o.nv};
    j["directions"] = job.directions().name();
    j["direction_count"] = job.directions().size();
    j["spp"] = o.spp;
    j["shadows"] = shadowModeName(o.shadows);
    j["method"] = o.method;
    j["plan"] = json::parse(job.plan().toJson());
    j["network_points"] = r.networkPoints;
    j["network_links"] = r.networkLinks;
    j["precompute_seconds"] = r.precomputeSeconds;
    j["render_seconds"] = r.renderSeconds;
    j["network_seconds"] = r.networkSeconds;
    j["network_light_seconds"] = r.lightSeconds;
    j["threads"] = est.threads;
    j["wall_seconds"] = r.wallSeconds;
    j["hit_map_seconds"] = r.hitMapSeconds;
    j["abrdf_seconds"] = r.evalSeconds;
    j["write_seconds"] = r.writeSeconds;
    j["estimated_seconds"] = est.seconds;
    j["hit_map_rays"] = r.hitMapRays;
    j["rays_per_second"] = rayRate;
    j["abrdf_values"] = r.abrdfValues;
    j["abrdf_evaluations_per_second"] = evalRate;
    j["brdf_evaluations"] = r.brdfEvaluations;
    j["peak_memory_bytes"] = r.peakRssBytes;
    j["output_bytes"] = r.outputBytes;
    j["chunks"] = r.chunks;
    j["chunks_resumed"] = r.chunksResumed;
    std::cout << j.dump(2) << std::endl;
  } else {
    std::printf("wrote %s (%s)\n", r.output.c_str(), formatBytes(double(r.outputBytes)).c_str());
    std::printf("  %d x %d texels, %d directions (%s), spp %d, shadows %s, %d thread(s)\n", o.nu,
                o.nv, job.directions().size(), job.directions().name().c_str(), o.spp,
                o.method == "pt" ? "exact (path traced)" : shadowModeName(o.shadows), est.threads);
    std::printf("  wall %s: hit maps %s (%.2f M rays/s), aBRDF %s (%.2f M values/s), write %s\n",
                formatSeconds(r.wallSeconds).c_str(), formatSeconds(r.hitMapSeconds).c_str(),
                rayRate / 1e6, formatSeconds(r.evalSeconds).c_str(), evalRate / 1e6,
                formatSeconds(r.writeSeconds).c_str());
    const EffectPlan& pl = job.plan();
    std::printf(
        "  effects: self-shadowing %s, inter-reflection %s (P = %d), %d channel(s), VMF %s\n",
        pl.selfShadowing ? "on" : "off", pl.interreflection ? "on" : "off", pl.bounces, pl.channels,
        pl.vmf ? "on" : "off");
    if (r.networkPoints)
      std::printf(
          "  precompute %s (network %s: %zu points, %zu links; hit maps %s), render %s "
          "(network light %s)\n",
          formatSeconds(r.precomputeSeconds).c_str(), formatSeconds(r.networkSeconds).c_str(),
          r.networkPoints, r.networkLinks, formatSeconds(r.hitMapSeconds).c_str(),
          formatSeconds(r.renderSeconds).c_str(), formatSeconds(r.lightSeconds).c_str());
    std::printf("  peak memory %s; chunks %d (%d resumed)\n",
                formatBytes(double(r.peakRssBytes)).c_str(), r.chunks, r.chunksResumed);
  }
  return 0;
}

namespace {

std::vector<DirectionPair> readPairs(const BrdfArgs& a, std::vector<std::array<double, 4>>* deg) {
  std::vector<DirectionPair> pairs;
  auto add = [&](const std::string& text, const std::string& where) {
    std::array<double, 4> v{};
    std::string t = text;
    std::replace(t.begin(), t.end(), ',', ' ');
    std::istringstream in(t);
    std::string rest;
    if (!(in >> v[0] >> v[1] >> v[2] >> v[3]) || (in >> rest))
      throw Error(where + ": expected θi,φi,θo,φo in degrees, got '" + text + "'");
    try {
      pairs.push_back(pairFromDegrees(v[0], v[1], v[2], v[3]));
    } catch (const Error& e) {
      throw Error(where + ": " + e.what());
    }
    deg->push_back(v);
  };
  for (const auto& p : a.pairs) add(p, "--pair");
  if (!a.pairsFile.empty()) {
    std::ifstream f(a.pairsFile);
    if (!f) throw Error(a.pairsFile + ": cannot open pairs file");
    std::string line;
    int n = 0;
    while (std::getline(f, line)) {
      ++n;
      const auto first = line.find_first_not_of(" \t\r");
      if (first == std::string::npos || line[first] == '#') continue;
      if (std::isalpha(static_cast<unsigned char>(line[first])) && n == 1) continue;  // header
      add(line, a.pairsFile + ":" + std::to_string(n));
    }
  }
  if (pairs.empty()) throw Error("no direction pairs: give --pair θi,φi,θo,φo or --pairs FILE.csv");
  return pairs;
}

}  // namespace

int brdf(const BrdfArgs& a) {
  if (a.samples < 1 || a.samples > 4096)
    throw Error("invalid --spp: samples per axis must be 1..4096");
  const Scene scene = loadScene(a.scene);
  std::vector<std::array<double, 4>> deg;
  const auto pairs = readPairs(a, &deg);
  ThreadLimit limit(a.threads);
  SimOptions o = optionsFromScene(scene);
  SimulationJob job(scene, o);
  if (a.method != "pt" && a.method != "direct")
    throw Error("unknown --method '" + a.method + "' (expected pt or direct)");
  if (a.bounces < 0 || a.bounces > 1024) throw Error("invalid --bounces: must be 0..1024");
  if (a.paths < 1 || a.paths > 65536) throw Error("invalid --paths: must be 1..65536");
  std::vector<Rgb> vals;
  if (a.method == "direct") {
    vals = averagedBrdf(job.tracer(), job.materials(), pairs, a.samples, o.seed);
  } else {
    PathSettings ps;
    ps.maxBounces = a.bounces;
    ps.seed = o.seed;
    vals = pathTracedBrdf(job.tracer(), job.materials(), pairs, a.samples, a.paths, ps);
  }
  if (a.json) {
    json arr = json::array();
    for (size_t k = 0; k < vals.size(); ++k)
      arr.push_back({{"theta_i", deg[k][0]},
                     {"phi_i", deg[k][1]},
                     {"theta_o", deg[k][2]},
                     {"phi_o", deg[k][3]},
                     {"abrdf", {vals[k].x, vals[k].y, vals[k].z}}});
    json j;
    j["scene"] = scene.name;
    j["method"] = a.method;
    j["bounces"] = a.bounces;
    j["samples"] = a.samples * a.samples * (a.method == "pt" ? a.paths : 1);
    j["pairs"] = arr;
    std::cout << j.dump(2) << std::endl;
  } else {
    std::printf("theta_i,phi_i,theta_o,phi_o,r,g,b\n");
    for (size_t k = 0; k < vals.size(); ++k)
      std::printf("%g,%g,%g,%g,%.7g,%.7g,%.7g\n", deg[k][0], deg[k][1], deg[k][2], deg[k][3],
                  vals[k].x, vals[k].y, vals[k].z);
  }
  return 0;
}

namespace {

DirectionSet storeDirections(const BtfReader& r) {
  DirectionSet d = DirectionSet::fromName(r.info().directionSet);
  if (d.size() != r.info().nDirs())
    throw Error("direction set of the store does not match its header");
  return d;
}

}  // namespace

int slice(const SliceArgs& a) {
  BtfReader r(a.btf);
  const BtfInfo& I = r.info();
  const DirectionSet dirs = storeDirections(r);
  double tl, pl;
  parseAnglePair(a.light, "--light", &tl, &pl);
  const auto lw = dirs.interpolate(deg2rad(tl), deg2rad(pl));
  const float scale = float(kPi) * a.exposure;
  if (!a.view.empty() == !a.texel.empty())
    throw Error(
        "slice needs exactly one of --view θ,φ (spatial image) or --texel u,v|avg (hemisphere)");
  if (!a.view.empty()) {
    double tv, pv;
    parseAnglePair(a.view, "--view", &tv, &pv);
    const auto vw = dirs.interpolate(deg2rad(tv), deg2rad(pv));
    std::vector<float> img(size_t(I.texels()) * 3, 0.f);
    for (const auto& v : vw)
      for (const auto& l : lw) {
        const auto part = r.readImage(v.index, l.index);
        const float w = float(v.weight * l.weight);
        for (size_t k = 0; k < img.size(); ++k) img[k] += w * part[k];
      }
    writeRgbImage(a.output, I.nu, I.nv, img, scale);
    std::printf("wrote %s: %dx%d texels, view (%g, %g), light (%g, %g) degrees\n", a.output.c_str(),
                I.nu, I.nv, tv, pv, tl, pl);
    return 0;
  }
  if (a.size < 8 || a.size > 8192) throw Error("invalid --size: must be 8..8192 pixels");
  // The texel's (or the tile average's) views × lights matrix, reduced to the chosen light.
  const int n = I.nDirs();
  std::vector<float> perView(size_t(n) * 3, 0.f);
  auto accumulate = [&](const float* m, float w) {
    for (int v = 0; v < n; ++v)
      for (const auto& l : lw)
        for (int c = 0; c < 3; ++c)
          perView[size_t(v) * 3 + c] +=
              w * float(l.weight) * m[(size_t(v) * n + size_t(l.index)) * 3 + c];
  };
  std::string what;
  if (a.texel == "avg") {
    const float w = 1.0f / float(I.texels());
    for (int c = 0; c < I.chunks(); ++c) {
      const auto data = r.readChunk(c);
      for (int64_t t = I.chunkBegin(c); t < I.chunkEnd(c); ++t)
        accumulate(&data[size_t(t - I.chunkBegin(c)) * I.texelBytes() / sizeof(float)], w);
    }
    what = "tile average";
  } else {
    int u = 0, v = 0;
    char comma = 0, extra = 0;
    if (std::sscanf(a.texel.c_str(), "%d%c%d%c", &u, &comma, &v, &extra) != 3 || comma != ',')
      throw Error("invalid --texel '" + a.texel + "': expected u,v (texel indices) or avg");
    if (u < 0 || v < 0 || u >= I.nu || v >= I.nv)
      throw Error("invalid --texel '" + a.texel + "': outside the " + std::to_string(I.nu) + "x" +
                  std::to_string(I.nv) + " texel grid");
    const auto m = r.readTexel(int64_t(v) * I.nu + u);
    accumulate(m.data(), 1.0f);
    what = "texel " + a.texel;
  }
  // Orthographic hemisphere: pixel (x, y) in the unit disk ↦ view with sinθ = r, φ = atan2(y, x);
  // +x to the right, +y up; outside the disk is black.
  const int S = a.size;
  std::vector<float> img(size_t(S) * S * 3, 0.f);
  for (int j = 0; j < S; ++j)
    for (int i = 0; i < S; ++i) {
      const double x = (i + 0.5) / S * 2 - 1, y = (j + 0.5) / S * 2 - 1;
      const double rr = std::sqrt(x * x + y * y);
      if (rr > 1) continue;
      const auto vw = dirs.interpolate(std::asin(std::min(rr, 1.0)), std::atan2(y, x));
      for (const auto& v : vw)
        for (int c = 0; c < 3; ++c)
          img[(size_t(j) * S + i) * 3 + c] += float(v.weight) * perView[size_t(v.index) * 3 + c];
    }
  writeRgbImage(a.output, S, S, img, scale);
  std::printf("wrote %s: aBRDF over views of the %s, light (%g, %g) degrees\n", a.output.c_str(),
              what.c_str(), tl, pl);
  return 0;
}

int info(const InfoArgs& a) {
  if (isCompressedFile(a.btf)) {
    const CompressedBtf c = readCompressed(a.btf);  // verifies every checksum or throws
    const BtfInfo& I = c.info;
    if (a.json) {
      json j;
      j["format"] = "btfstudio-compressed-btf";
      j["codec"] = c.codec;
      j["colour"] = c.colour;
      j["params"] = json::parse(c.paramsJson);
      j["stats"] = json::parse(c.statsJson);
      j["texels"] = {I.nu, I.nv};
      j["directions"] = I.directionSet;
      j["file_bytes"] = c.fileBytes();
      j["ratio"] = c.ratio();
      j["verified"] = true;
      json arrays = json::array();
      for (const auto& x : c.arrays)
        arrays.push_back({{"name", x.name},
                          {"rows", x.rows},
                          {"cols", x.cols},
                          {"type", x.type == ArrayType::F16 ? "f16" : "f32"}});
      j["arrays"] = arrays;
      std::cout << j.dump(2) << std::endl;
    } else {
      std::printf("%s: compressed BTF, codec %s (%s), %s, ratio 1:%.0f\n", a.btf.c_str(),
                  c.codec.c_str(), c.colour.c_str(), formatBytes(double(c.fileBytes())).c_str(),
                  c.ratio());
      std::printf("  scene        %s (hash %s)\n", I.sceneName.c_str(), I.sceneHash.c_str());
      std::printf("  texels       %d x %d\n", I.nu, I.nv);
      std::printf("  directions   %s (%d)\n", I.directionSet.c_str(), I.nDirs());
      std::printf("  params       %s\n  stats        %s\n", c.paramsJson.c_str(),
                  c.statsJson.c_str());
      for (const auto& x : c.arrays)
        std::printf("  array        %-18s %lld x %lld %s\n", x.name.c_str(), (long long)x.rows,
                    (long long)x.cols, x.type == ArrayType::F16 ? "f16" : "f32");
      std::printf("  checksums    all verified\n");
    }
    return 0;
  }
  BtfReader r(a.btf);
  const BtfInfo& I = r.info();
  const auto v = r.verify();
  const bool ok = v.badChunks.empty() && v.vmfOk;
  if (a.json) {
    json j = json::parse(r.headerJson());
    j["file_bytes"] = r.layout().totalBytes;
    j["verified"] = ok;
    j["bad_chunks"] = v.badChunks;
    j["vmf_ok"] = v.vmfOk;
    std::cout << j.dump(2) << std::endl;
  } else {
    std::printf("%s: raw BTF store, %s\n", a.btf.c_str(),
                formatBytes(double(r.layout().totalBytes)).c_str());
    std::printf("  scene        %s (hash %s)\n", I.sceneName.c_str(), I.sceneHash.c_str());
    std::printf("  tile         %g x %g\n", I.Lx, I.Ly);
    std::printf("  texels       %d x %d\n", I.nu, I.nv);
    std::printf("  directions   %s (%d, shared by view and light; %lld pairs)\n",
                I.directionSet.c_str(), I.nDirs(), static_cast<long long>(I.nDirs()) * I.nDirs());
    std::printf("  settings     spp %d, shadows %s (bias %g), seed %llu\n", I.spp,
                I.shadows.c_str(), I.shadowBias, static_cast<unsigned long long>(I.seed));
    std::printf("  plan         %s\n", I.plan.c_str());
    std::printf("  chunks       %d of %d texel(s)\n", I.chunks(), I.chunkTexels);
    std::printf("  checksums    %s", ok ? "all verified\n" : "MISMATCH:");
    if (!ok) {
      for (int c : v.badChunks) std::printf(" chunk %d", c);
      if (!v.vmfOk) std::printf(" visibility-map");
      std::printf("\n");
    }
  }
  if (!ok)
    throw Error(a.btf + ": corrupted: " + std::to_string(v.badChunks.size()) + " bad chunk(s)" +
                (v.vmfOk ? "" : ", bad visibility map"));
  return 0;
}

int bench(const BenchArgs& a) {
  const Scene scene = loadScene(a.scene);
  ThreadLimit limit(a.threads);
  if (a.repeat < 1) throw Error("invalid --repeat: must be >= 1");
  json results = json::array();
  std::stringstream modes(a.shadows);
  std::string mode;
  while (std::getline(modes, mode, ',')) {
    SimOptions o = optionsFromScene(scene);
    parseTexels(a.texels, &o.nu, &o.nv);
    o.directions = a.dirs;
    o.spp = a.spp;
    o.shadows = parseShadowMode(mode);
    applyEffects(a.effects, &o);
    o.progress = false;
    o.memoryBudget = uint64_t(2) << 30;
    SimulationJob job(scene, o);
    const SimEstimate est = job.estimate("");
    std::vector<double> wall, hit, eval, rays, rates, rss;
    for (int k = 0; k < a.repeat; ++k) {
      const SimReport r = job.run("", est);
      wall.push_back(r.wallSeconds);
      hit.push_back(r.hitMapSeconds);
      eval.push_back(r.evalSeconds);
      rays.push_back(double(r.hitMapRays) / r.hitMapSeconds);
      rates.push_back(double(r.abrdfValues) / r.evalSeconds);
      rss.push_back(double(r.peakRssBytes));
      std::fprintf(stderr,
                   "bench %s run %d/%d: %.2f s (hit maps %.2f s, aBRDF %.2f s, %.1f M values/s; "
                   "P = %d)\n",
                   mode.c_str(), k + 1, a.repeat, r.wallSeconds, r.hitMapSeconds, r.evalSeconds,
                   rates.back() / 1e6, job.plan().bounces);
    }
    auto median = [](std::vector<double> v) {
      std::sort(v.begin(), v.end());
      return v[v.size() / 2];
    };
    json j;
    j["shadows"] = mode;
    j["method"] = o.method;
    j["interreflection"] = job.plan().interreflection;
    j["bounces"] = job.plan().bounces;
    j["texels"] = {o.nu, o.nv};
    j["directions"] = job.directions().name();
    j["pairs"] = int64_t(job.directions().size()) * job.directions().size();
    j["spp"] = o.spp;
    j["threads"] = est.threads;
    j["runs"] = a.repeat;
    j["median_wall_seconds"] = median(wall);
    j["median_hit_map_seconds"] = median(hit);
    j["median_abrdf_seconds"] = median(eval);
    j["median_rays_per_second"] = median(rays);
    j["median_abrdf_values_per_second"] = median(rates);
    j["estimated_seconds"] = est.seconds;
    j["peak_rss_bytes"] = *std::max_element(rss.begin(), rss.end());
    j["memory_budget_bytes"] = o.memoryBudget;
    results.push_back(j);
    if (!a.json)
      std::printf(
          "%-5s %dx%d texels x %s^2, spp %d, %d thread(s): median wall %.2f s = hit maps %.2f s "
          "(%.2f M rays/s) + aBRDF %.2f s (%.1f M values/s); peak RSS %s\n",
          mode.c_str(), o.nu, o.nv, job.directions().name().c_str(), o.spp, est.threads,
          median(wall), median(hit), median(rays) / 1e6, median(eval), median(rates) / 1e6,
          formatBytes(*std::max_element(rss.begin(), rss.end())).c_str());
  }
  if (a.json) std::cout << results.dump(2) << std::endl;
  return 0;
}

namespace {
int writeText(const std::string& s, const std::string& output) {
  if (output.empty()) {
    std::cout << s;
  } else {
    std::ofstream f(output, std::ios::binary);
    if (!f) throw Error(output + ": cannot write");
    f << s;
  }
  return 0;
}
}  // namespace

int schema(const std::string& output) {
  return writeText(sceneJsonSchema(), output);
}
int sceneDoc(const std::string& output) {
  return writeText(sceneParamsMarkdown(), output);
}

int plan(const PlanArgs& a) {
  const Scene scene = loadScene(a.scene);
  SimOptions o = sceneOptions(scene, a.texels, a.dirs, a.spp, a.shadows);
  applyEffects(a.effects, &o);
  o.progress = false;
  ThreadLimit limit(a.threads);
  SimulationJob job(scene, o);
  const SimEstimate est = job.estimate("");
  const EffectPlan& p = job.plan();
  if (a.json) {
    json j = json::parse(p.toJson());
    j["scene"] = scene.name;
    j["method"] = o.method;
    j["texels"] = {o.nu, o.nv};
    j["directions"] = job.directions().name();
    j["triangles"] = job.geometry().triangleCount();
    j["estimate"]["seconds"] = est.seconds;
    j["estimate"]["hit_map_seconds"] = est.hitMapSeconds;
    j["estimate"]["abrdf_seconds"] = est.evalSeconds;
    j["estimate"]["network_light_seconds"] = est.lightSeconds;
    j["estimate"]["gather_seconds"] = est.gatherSeconds;
    j["estimate"]["memory_bytes"] = est.memoryBytes;
    j["estimate"]["network_bytes"] = est.networkBytes;
    if (const PointNetwork* n = job.network()) {
      j["network"]["points"] = n->points().size();
      j["network"]["links"] = n->links().size();
      j["network"]["voxels"] = n->settings().voxels;
      j["network"]["build_seconds"] = n->buildSeconds();
    }
    std::cout << j.dump(2) << std::endl;
    return 0;
  }
  std::printf("effect plan for %s (%dx%d texels, %s, %d directions, method %s):\n",
              scene.name.c_str(), o.nu, o.nv, job.directions().name().c_str(),
              job.directions().size(), o.method.c_str());
  printPlan(p, stdout);
  std::printf("geometry: %zu triangles (%zu in the tracer with the periodic copies)\n",
              job.geometry().triangleCount(), job.tracer().embreeTriangles());
  std::printf(
      "analysis: %s; ρ_max %.3g; α max %.3g, mean %.3g; %lld of %lld occlusion probes "
      "occluded\n",
      p.flat ? "flat tile" : "relief", p.rhoMax, p.alphaMax, p.alphaMean,
      (long long)p.occludedTests, (long long)p.occlusionTests);
  if (const PointNetwork* n = job.network())
    std::printf("point network: %zu points, %zu links (%d voxels per side), built in %s\n",
                n->points().size(), n->links().size(), n->settings().voxels,
                formatSeconds(n->buildSeconds()).c_str());
  std::printf(
      "estimate: %s (hit maps %s, aBRDF %s of which final gather %s, network light %s) on "
      "%d thread(s); memory %s\n",
      formatSeconds(est.seconds).c_str(), formatSeconds(est.hitMapSeconds).c_str(),
      formatSeconds(est.evalSeconds).c_str(), formatSeconds(est.gatherSeconds).c_str(),
      formatSeconds(est.lightSeconds).c_str(), est.threads,
      formatBytes(double(est.memoryBytes)).c_str());
  return 0;
}

namespace {
std::vector<std::string> splitList(const std::string& s, const std::string& what) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  if (out.empty()) throw Error("empty list for " + what);
  return out;
}
std::vector<int> intList(const std::string& s, const std::string& what, int lo, int hi) {
  std::vector<int> out;
  for (const auto& t : splitList(s, what)) {
    char* end = nullptr;
    const long v = std::strtol(t.c_str(), &end, 10);
    if (*end || v < lo || v > hi)
      throw Error("invalid " + what + " value '" + t + "': expected an integer in " +
                  std::to_string(lo) + ".." + std::to_string(hi));
    out.push_back(int(v));
  }
  return out;
}
}  // namespace

namespace {

// The compression knobs of the study: one simulated BTF (the base configuration), every codec
// × β × components compressed and compared with it.
void compressionStudy(const StudyArgs& a, const Scene& scene, const StudyOptions& o) {
  std::vector<double> betas;
  for (const auto& b : splitList(a.betas, "--betas")) {
    char* end = nullptr;
    const double v = std::strtod(b.c_str(), &end);
    if (end == b.c_str() || *end || !(v > 0 && v <= 1))
      throw Error("invalid --betas value '" + b + "': expected a number in (0, 1]");
    betas.push_back(v);
  }
  const std::vector<int> comps = intList(a.components, "--components", 0, 4096);
  std::vector<CodecSettings> settings;
  for (const auto& c : splitList(a.codecs, "--codecs")) {
    CodecArgs ca = a.codec;
    ca.codec = c;
    for (double beta : c == "nmf" ? betas : std::vector<double>{betas[0]})
      for (int comp : comps) {
        ca.beta = beta;
        ca.components = comp;
        settings.push_back(codecSettings(ca));
      }
  }
  std::filesystem::create_directories(a.output);
  const std::string raw = a.output + "/base.btf";
  SimOptions so = sceneOptions(scene, std::to_string(o.nu) + "x" + std::to_string(o.nv),
                               o.base.dirs, o.base.spp, shadowModeName(o.base.shadows));
  so.method = o.base.method;
  so.progress = !a.quiet;
  {
    SimulationJob job(scene, so);
    const SimEstimate est = job.estimate(raw);
    if (!est.refusal.empty()) throw Error("compression study: " + est.refusal);
    std::fprintf(stderr, "compression study: simulating the base configuration into %s\n",
                 raw.c_str());
    job.run(raw, est);
  }
  const auto ref = openBtf(raw);
  struct Row {
    CodecSettings s;
    double seconds, ratio, rmse, rel, psnr;
    uint64_t bytes, rss;
    std::string chosen;
    bool pareto = false;
  };
  std::vector<Row> rows;
  for (const auto& cs : settings) {
    CompressReport rep;
    CompressedBtf c = compressStore(raw, cs, !a.quiet, nullptr, &rep);
    const json params = json::parse(c.paramsJson);
    std::string chosen;
    if (params.contains("components_per_channel")) chosen = params["components_per_channel"].dump();
    if (params.contains("channels")) {
      json ch = json::array();
      for (const auto& x : params["channels"])
        ch.push_back({x["slots"], x["components_view"], x["components_light"]});
      chosen = ch.dump();
    }
    const auto dec = makeDecoder(std::move(c));
    const ErrorReport e = compareBtfs(*ref, *dec, false);
    rows.push_back({cs, rep.seconds, rep.ratio, e.rmse, e.relRmse, e.psnr, rep.fileBytes,
                    rep.peakRssBytes, chosen});
  }
  // Pareto front on (size, error): no other row is both smaller and more accurate.
  for (auto& r : rows) {
    r.pareto = true;
    for (const auto& q : rows)
      if (&q != &r && q.bytes <= r.bytes && q.rel <= r.rel && (q.bytes < r.bytes || q.rel < r.rel))
        r.pareto = false;
  }
  std::ofstream csv(a.output + "/compression.csv");
  csv << "codec,colour,beta,components,chosen,ratio,bytes,rmse,relative_rmse,psnr_db,seconds,"
         "peak_rss_bytes,pareto\n";
  std::ofstream md(a.output + "/compression.md");
  md << "# Compression study: " << scene.name << ", " << o.nu << "x" << o.nv << " texels, "
     << o.base.dirs << ", spp " << o.base.spp << "\n\n"
     << "Error against the uncompressed simulation (" << raw << ").\n\n"
     << "| codec | β | components (chosen) | ratio | RMSE | rel. RMSE | PSNR | time | peak RSS | "
        "Pareto |\n|---|---|---|---|---|---|---|---|---|---|\n";
  std::printf("%-8s %6s %-24s %8s %9s %9s %8s %8s\n", "codec", "beta", "components", "ratio",
              "RMSE", "rel.RMSE", "PSNR", "time");
  for (const auto& r : rows) {
    const std::string comp = (r.s.components ? std::to_string(r.s.components) : "auto") +
                             (r.chosen.empty() ? "" : " " + r.chosen);
    csv << r.s.codec << "," << r.s.colour << "," << r.s.beta << "," << r.s.components << ",\""
        << r.chosen << "\"," << r.ratio << "," << r.bytes << "," << r.rmse << "," << r.rel << ","
        << r.psnr << "," << r.seconds << "," << r.rss << "," << (r.pareto ? 1 : 0) << "\n";
    char line[512];
    std::snprintf(line, sizeof line,
                  "| %s | %s | %s | 1:%.0f | %.4g | %.2f %% | %.1f dB | %.1f s | %s | %s |\n",
                  r.s.codec.c_str(),
                  r.s.codec == "nmf" ? std::to_string(r.s.beta).substr(0, 6).c_str() : "–",
                  comp.c_str(), r.ratio, r.rmse, 100 * r.rel, r.psnr, r.seconds,
                  formatBytes(double(r.rss)).c_str(), r.pareto ? "*" : "");
    md << line;
    std::printf("%-8s %6.4f %-24s %7.0f:1 %9.4g %8.2f%% %7.1fdB %7.1fs %s\n", r.s.codec.c_str(),
                r.s.beta, comp.substr(0, 24).c_str(), r.ratio, r.rmse, 100 * r.rel, r.psnr,
                r.seconds, r.pareto ? "*" : "");
  }
  std::filesystem::remove(raw);
  std::printf("wrote %s/compression.csv, compression.md\n", a.output.c_str());
}

}  // namespace

int study(const StudyArgs& a) {
  const Scene scene = loadScene(a.scene);
  StudyOptions o;
  parseTexels(a.texels, &o.nu, &o.nv);
  o.methods = splitList(a.methods, "--method");
  for (const auto& m : o.methods)
    if (m != "network" && m != "pt")
      throw Error("invalid --method value '" + m + "': expected network or pt");
  o.paths = intList(a.paths, "--paths", 1, 4096);
  o.dirs = splitList(a.dirs, "--dirs");
  for (const auto& d : o.dirs) DirectionSet::fromName(d);  // validate early
  o.spp = intList(a.spp, "--spp", 1, 64);
  for (const auto& m : splitList(a.shadows, "--shadows")) {
    const ShadowMode sm = parseShadowMode(m);
    if (sm == ShadowMode::None) throw Error("--shadows: use map or rays");
    o.shadows.push_back(sm);
  }
  o.voxels = intList(a.voxels, "--network-voxels", 0, 1024);
  o.gather = intList(a.gather, "--gather", 1, 16);
  o.links = intList(a.links, "--links", 1, 256);
  o.bounces = intList(a.bounces, "--bounces", 1, 64);
  o.base = {o.methods[0], o.dirs[0],  o.spp[0],     o.shadows[0], o.voxels[0],
            o.gather[0],  o.links[0], o.bounces[0], o.paths[0]};
  if (o.paths.size() == 1 && o.methods.size() == 1) o.paths.clear();
  o.grid = a.grid;
  if (a.referenceSpp < 8 || a.referenceSpp > 4096)
    throw Error("invalid --reference-spp: samples per axis must be 8..4096");
  o.referenceSamples = a.referenceSpp;
  o.progress = !a.quiet;
  ThreadLimit limit(a.threads);
  const auto configs = studyConfigs(o);
  std::fprintf(stderr,
               "study of %s: %zu configuration(s) at %dx%d texels, reference %d² paths per "
               "probe pair\n",
               scene.name.c_str(), configs.size(), o.nu, o.nv, o.referenceSamples);
  const Study st = runStudy(scene, o);
  writeStudy(st, a.output);
  std::printf("%-52s %9s %8s %8s %8s %7s\n", "configuration", "time", "interp.", "at set", "image",
              "Pareto");
  for (const auto& r : st.results)
    std::printf("%-52s %8.2fs %7.2f%% %7.2f%% %7.1f%% %7s\n", r.config.label().c_str(), r.seconds,
                100 * r.probeRelRmse, 100 * r.setRelRmse, 100 * r.imageRelRmse,
                r.pareto ? "*" : "");
  std::printf("wrote %s/study.csv, study.md, study.svg\n", a.output.c_str());
  if (!a.codecs.empty()) compressionStudy(a, scene, o);
  return 0;
}

}  // namespace btf::cli

namespace btf::cli {

int compress(const CompressArgs& a) {
  CodecSettings cs = codecSettings(a.codec);
  cs.memoryBudget = parseBytes(a.memoryBudget);
  ThreadLimit limit(a.threads);
  CompressReport rep;
  const CompressedBtf c = compressStore(a.input, cs, !a.quiet, nullptr, &rep);
  writeCompressed(a.output, c);
  ErrorReport err;
  if (a.compare) {
    const auto ref = openBtf(a.input);
    const auto dec = makeDecoder(c);
    err = compareBtfs(*ref, *dec, !a.quiet);
  }
  if (a.json) {
    json j;
    j["input"] = a.input;
    j["output"] = a.output;
    j["codec"] = json::parse(c.paramsJson);
    j["stats"] = json::parse(c.statsJson);
    j["seconds"] = rep.seconds;
    j["train_seconds"] = rep.trainSeconds;
    j["encode_seconds"] = rep.encodeSeconds;
    j["finish_seconds"] = rep.finishSeconds;
    j["raw_bytes"] = double(c.info.texels()) * c.info.nDirs() * c.info.nDirs() * 12.0;
    j["compressed_bytes"] = rep.fileBytes;
    j["ratio"] = rep.ratio;
    j["peak_memory_bytes"] = rep.peakRssBytes;
    if (a.compare) j["error"] = json::parse(errorReportJson(err));
    std::cout << j.dump(2) << std::endl;
  } else {
    std::printf("wrote %s\n", a.output.c_str());
    printCompressed(c, rep.seconds, rep.peakRssBytes);
    if (a.compare)
      std::printf("  error: RMSE %.5g, relative RMSE %.3f %%, PSNR %.2f dB (peak %.4g)\n", err.rmse,
                  100 * err.relRmse, err.psnr, err.peak);
  }
  return 0;
}

int compare(const CompareArgs& a) {
  ThreadLimit limit(a.threads);
  const auto A = openBtf(a.a);
  const auto B = openBtf(a.b);
  const ErrorReport r = compareBtfs(*A, *B, !a.quiet, a.worst);
  if (!a.maps.empty()) writeErrorMaps(r, a.maps);
  auto ratioOf = [](const std::string& p) {
    return isCompressedFile(p) ? readCompressed(p).ratio() : 1.0;
  };
  const double ratioA = ratioOf(a.a), ratioB = ratioOf(a.b);
  if (a.json) {
    json j = json::parse(errorReportJson(r));
    j["a"] = {{"path", a.a}, {"kind", A->kind()}, {"ratio", ratioA}};
    j["b"] = {{"path", a.b}, {"kind", B->kind()}, {"ratio", ratioB}};
    if (!a.maps.empty()) j["maps"] = a.maps;
    std::cout << j.dump(2) << std::endl;
    return 0;
  }
  std::printf("A %s (%s, ratio 1:%.0f)\nB %s (%s, ratio 1:%.0f)\n", a.a.c_str(), A->kind().c_str(),
              ratioA, a.b.c_str(), B->kind().c_str(), ratioB);
  std::printf(
      "RMSE %.6g (1/sr), relative RMSE %.3f %%, PSNR %.2f dB (peak %.5g), max |error| %.5g\n",
      r.rmse, 100 * r.relRmse, r.psnr, r.peak, r.maxAbs);
  std::printf("worst texels (u, v: RMSE):");
  for (const auto& w : r.worstTexels)
    std::printf(" (%lld, %lld: %.4g)", (long long)(w.index % r.nu), (long long)(w.index / r.nu),
                w.rmse);
  std::printf("\nworst directions (view θ,φ / light θ,φ: RMSE):");
  const auto& dirs = A->info().dirsDeg;
  for (const auto& w : r.worstDirections) {
    const auto& v = dirs[size_t(w.index / r.nDirs)];
    const auto& l = dirs[size_t(w.index % r.nDirs)];
    std::printf(" (%.1f,%.1f / %.1f,%.1f: %.4g)", v[0], v[1], l[0], l[1], w.rmse);
  }
  std::printf("\n");
  if (!a.maps.empty())
    std::printf("maps: %s/texel_rmse.{exr,png}, %s/direction_rmse.{exr,png}\n", a.maps.c_str(),
                a.maps.c_str());
  return 0;
}

int exportBtf(const ExportArgs& a) {
  ThreadLimit limit(a.threads);
  const auto d = openBtf(a.input);
  if (a.format == "ubo2003") {
    const int64_t n = exportUbo2003(*d, a.output, !a.quiet);
    std::printf("wrote %lld images and btf_export.json under %s\n", (long long)n, a.output.c_str());
  } else if (a.format == "ubo2014") {
    if (a.components < 1) throw Error("--components: must be ≥ 1");
    const Ubo2014Report r = exportUbo2014(*d, a.output, a.components, !a.quiet);
    std::printf(
        "wrote %s (%s): DFMF, colour model 0, fp16, components R %d G %d B %d, "
        "factorisation relative RMSE %.3f %% (training texels)\n",
        a.output.c_str(), formatBytes(double(r.bytes)).c_str(), r.components[0], r.components[1],
        r.components[2], 100 * r.relRmse);
  } else if (a.format == "merl") {
    const MerlReport r = exportMerl(*d, a.output, a.phiSamples, !a.quiet);
    std::printf("wrote %s: 90x90x180 bins, %lld missing (below the horizon), φh spread %.1f %%\n",
                a.output.c_str(), (long long)r.missingBins, 100 * r.anisotropy);
    if (r.anisotropy > 0.1)
      std::fprintf(
          stderr,
          "btfsim: warning: the texel-averaged aBRDF varies by %.0f %% over the half-vector "
          "azimuth; MERL is isotropic, so the export averages it away\n",
          100 * r.anisotropy);
  } else {
    throw Error("--format: unknown export format '" + a.format +
                "' (expected ubo2003, ubo2014 or merl)");
  }
  return 0;
}

}  // namespace btf::cli
