// Use cases of the simulator: simulate (into a store, or streamed into a codec), plan, bench and
// brdf. The only place where the simulator's chunks meet an encoder and a writer.
#include <btf/compress/compress.h>
#include <btf/compress/mip.h>
#include <btf/core/input_file.h>
#include <btf/core/sysinfo.h>
#include <btf/ops/internal.h>
#include <btf/scene/scene.h>
#include <btf/sim/brdf_probe.h>
#include <btf/sim/path_tracer.h>
#include <btf/sim/simulator.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace btf::ops::detail {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string planText(const EffectPlan& p) {
  std::string s;
  for (const auto& d : p.decisions)
    s += format("  %-16s %-4s %s%s%s\n", d.effect.c_str(), d.value.c_str(),
                d.forced ? "[forced] " : "", d.reason.c_str(),
                d.secondsSaved > 0   ? (" — saves ~" + formatSeconds(d.secondsSaved)).c_str()
                : d.secondsSaved < 0 ? (" — costs ~" + formatSeconds(-d.secondsSaved)).c_str()
                                     : "");
  return s;
}

// "adaptive 2x2..8x8", "uniform 4x4", "exact by area" (every face flat) or "exact by area +
// uniform 4x4" (smooth faces sampled on the hit maps).
std::string samplingName(const SimulationJob& job) {
  const SimOptions& o = job.options();
  if (const ExactDirect* ex = job.exactDirect())
    return ex->allFlat() ? std::string("exact by area")
                         : format("exact by area + uniform %dx%d", job.mapSpp(), job.mapSpp());
  return job.adaptive()
             ? format("adaptive 2x2..%dx%d", o.adaptiveSettings.maxK, o.adaptiveSettings.maxK)
             : format("uniform %dx%d", o.spp, o.spp);
}

// The samples the texels took and the run's own error estimate (adaptive runs).
std::string samplingText(const SimReport& sr) {
  if (!sr.adaptive) return "";
  return format("  samples per value: mean %.1f (%s); estimated per-value error %.2f %%\n",
                sr.meanSamples, sr.samplingText.c_str(), 100.0 * sr.estimatedError);
}

std::string estimateText(const SimEstimate& e, const SimOptions& o, bool streamed) {
  std::string disk =
      streamed ? "disk: no raw file"
               : "disk " + formatBytes(double(e.diskBytes)) +
                     (e.freeDiskBytes ? " (" + formatBytes(double(e.freeDiskBytes)) + " free)"
                                      : std::string(" (free space unknown)"));
  return format(
      "estimate: %s (hit maps %s, aBRDF %s) on %d thread(s); memory %s of a %s budget; "
      "%s; %d chunk(s) of %d texel(s)",
      formatSeconds(e.seconds).c_str(), formatSeconds(e.hitMapSeconds).c_str(),
      formatSeconds(e.evalSeconds).c_str(), e.threads, formatBytes(double(e.memoryBytes)).c_str(),
      formatBytes(double(o.memoryBudget)).c_str(), disk.c_str(), e.chunks, e.chunkTexels);
}

json planJson(const EffectPlan& p) {
  return json::parse(p.toJson());
}

}  // namespace

ClusterFigures clusterFigures(Comm& comm, double texels, double texelBytes, uint64_t commBytes,
                              double seconds, int lightsSolved, uint64_t giShareBytes) {
  // Per rank: texels, bytes of aBRDF it computed or encoded, bytes it sent and received, the
  // seconds of its own share, and its part of the network's light solve.
  const std::vector<double> mine = {double(texels), double(texels) * texelBytes, double(commBytes),
                                    seconds,         double(lightsSolved),       double(giShareBytes)};
  ClusterFigures f;
  double slowest = 0, total = 0;
  for (const std::string& s : comm.allgather(packDoubles(mine))) {
    const std::vector<double> v = unpackDoubles(s);
    const double share = v[1] > 0 ? v[2] / v[1] : 0;
    f.maxCommunicatedFraction = std::max(f.maxCommunicatedFraction, share);
    f.maxCommunicatedBytes = std::max(f.maxCommunicatedBytes, v[2]);
    slowest = std::max(slowest, v[3]);
    total += v[3];
    f.perRank.push_back({v[0], v[1], v[2], share, v[3], v[4], v[5]});
  }
  f.ranks = comm.size();
  f.communicator = comm.describe();
  f.balance = slowest > 0 ? total / (slowest * comm.size()) : 1.0;
  return f;
}

std::string clusterText(const ClusterFigures& cl) {
  std::string t = format("  cluster: %s; balance %.0f %% (mean / slowest rank); per rank:",
                         cl.communicator.c_str(), 100 * cl.balance);
  int r = 0;
  for (const auto& x : cl.perRank) {
    t += format(" [%d] %g texels in %.1f s, %s sent+received (%.3f %% of its data)", r++, x.texels,
                x.seconds, formatBytes(x.communicatedBytes).c_str(),
                100 * x.communicatedFraction);
    if (x.lightsSolved > 0)
      t += format(", %g network lights solved (GI precompute %s shared)", x.lightsSolved,
                  formatBytes(x.giShareBytes).c_str());
  }
  return t + "\n";
}

namespace {

// simulate --compress C --mip (docs/mip.md): the store, then its pyramid, then no store.
void simulatePyramid(const Call& c, SimulationJob& job, const SimEstimate& est,
                     const std::string& level0) {
  const Request& r = c.r;
  const std::string& output = r.s("output");
  const CodecSettings cs = codecSettings(r, r.s("compress"));
  c.notice("--mip: level 0 goes to the temporary store " + level0 +
           " (removed once the pyramid is written; --resume continues it)");
  const auto start = Clock::now();
  const SimReport sr = job.run(level0, est, c.ctx.cancel);
  if (!sr.resumeNote.empty()) c.warn(sr.resumeNote);
  PyramidReport rep;
  const CompressedBtf b = compressPyramid(level0, cs, c.progress(), c.ctx.cancel, &rep);
  c.ctx.check("encoder");
  writeCompressed(output, b);
  std::error_code ec;
  std::filesystem::remove(level0, ec);
  const double wall = since(start);
  const uint64_t rss = peakRssBytes();
  warnTarget(c, b);
  SimulateResult& res = std::get<SimulateResult>(c.rep.result);
  if (sr.adaptive) res.samples = json::parse(sr.samplingJson);
  SimulateResult::Compressed& z = res.compressed.emplace();
  z.file = codecFigures(b, double(b.info.texels()) * b.info.texelBytes(), b.fileBytes(), b.ratio(),
                        rss);
  z.wallSeconds = wall;
  z.simulateSeconds = sr.wallSeconds;
  z.levelSeconds = rep.levelSeconds;
  z.encodeSeconds = rep.trainSeconds + rep.encodeSeconds;
  z.finishSeconds = rep.finishSeconds;
  c.rep.text = format(
                   "wrote %s (a pyramid of %zu texel levels)\n  wall %s: simulation %s, "
                   "levels %s, encoding %s, finish %s\n",
                   output.c_str(), b.levels.size(), formatSeconds(wall).c_str(),
                   formatSeconds(sr.wallSeconds).c_str(), formatSeconds(rep.levelSeconds).c_str(),
                   formatSeconds(rep.trainSeconds + rep.encodeSeconds).c_str(),
                   formatSeconds(rep.finishSeconds).c_str()) +
               samplingText(sr) + compressedText(b, wall, rss) + levelsReport(rep, &z.levels);
  c.rep.summary = format("wrote %s, %zu levels, ratio 1:%.0f (of level 0) in %s", output.c_str(),
                         b.levels.size(), b.ratio(), formatSeconds(wall).c_str());
}

}  // namespace

void simulate(const Call& c) {
  const Request& r = c.r;
  Comm& comm = c.ctx.processes();
  const std::string& output = r.s("output");
  const std::string codec = r.s("compress");
  // --compress C --mip: level 0 through a temporary raw store (the levels need its rows in
  // order), then the pyramid, then the store is removed.
  const bool mip = r.b("mip");
  if (mip && codec.empty()) throw Error("--mip: give --compress CODEC too (a pyramid is a .cbtf)");
  if (mip && comm.distributed())
    throw Error("simulate --compress --mip runs on one process: launch it without mpirun/srun");
  const std::string level0 = output + ".level0.btf";
  // Every rank of a cluster job builds the same job (checked) and agrees before the work.
  std::unique_ptr<SimulationJob> jobPtr;
  SimOptions o;
  SimEstimate est;
  collectively(comm, [&] {
    const Scene scene = c.scene();
    o = simOptions(scene, r);
    o.progress = c.progress();
    if (!codec.empty()) {
      const auto& names = codecNames();
      if (std::find(names.begin(), names.end(), codec) == names.end())
        throw Error("--compress: unknown codec '" + codec +
                    "' (expected nmf, svd, perview, lpca, tensor or neural)");
    }
    jobPtr = std::make_unique<SimulationJob>(scene, o);
    jobPtr->setCancel(c.ctx.cancel);
    est = jobPtr->estimate(codec.empty() ? output : mip ? level0 : std::string());
  });
  SimulationJob& job = *jobPtr;
  const Scene& scene = job.scene();
  requireSame(comm, "the scene and its geometry", job.sceneHash());
  job.setComm(&comm);
  c.notice("effect plan (" + o.method + "):\n" + planText(job.plan()));
  c.notice(estimateText(est, o, !codec.empty() && !mip));
  if (comm.distributed())
    // Every rank repeats the hit maps; the network's lights and the aBRDF are shared.
    c.notice(format(
        "cluster job: %s; %d chunk(s) over %d rank(s)%s, %d thread(s) each; estimate "
        "%s (each rank: hit maps %s, network light %s, aBRDF %s)",
        comm.describe().c_str(), est.chunks, comm.size(),
        est.chunks < 2 * comm.size()
            ? " (fewer than twice the ranks: each chunk is cut into pieces of views, gathered on "
              "one rank to be written)"
            : "",
        est.threads,
        formatSeconds(est.hitMapSeconds + (est.lightSeconds + est.evalSeconds) / comm.size())
            .c_str(),
        formatSeconds(est.hitMapSeconds).c_str(),
        formatSeconds(est.lightSeconds / comm.size()).c_str(),
        formatSeconds(est.evalSeconds / comm.size()).c_str()));
  collectively(comm, [&] {
    if (!est.refusal.empty())
      throw Error(
          "refusing to start: " +
          (comm.distributed()
               ? format("rank %d of %d (the budget is per rank): ", comm.rank(), comm.size())
               : std::string()) +
          est.refusal);
  });
  SimulateResult& res = c.rep.result.emplace<SimulateResult>();
  res.output = output;
  res.scene = scene.name;
  res.nu = o.nu, res.nv = o.nv;
  res.directions = job.directions().name();
  res.directionCount = job.directions().size();
  res.spp = o.spp;
  res.sampling = samplingName(job);
  res.visibility = job.visibilityName();
  res.shadows = shadowModeName(o.shadows);
  res.method = o.method;
  res.plan = planJson(job.plan());
  res.threads = est.threads;
  res.estimatedSeconds = est.seconds;
  c.rep.outputs.push_back(output);
  if (mip) {
    simulatePyramid(c, job, est, level0);
    return;
  }
  if (!codec.empty()) {
    // Streamed: the training texels first, then every chunk straight into the encoder.
    const CodecSettings cs = codecSettings(r, codec);
    const BtfInfo info = job.storeInfo(est.chunkTexels);
    auto enc = makeEncoder(cs, info, c.ctx.cancel);
    const double trainBytes = double(enc->trainingTexels().size()) * double(info.texelBytes());
    const double need = double(est.memoryBytes) + double(enc->memoryBytes()) + trainBytes;
    if (need > double(o.memoryBudget))
      throw Error("refusing to start: simulating and compressing needs about " + formatBytes(need) +
                  " (simulation " + formatBytes(double(est.memoryBytes)) + ", encoder " +
                  formatBytes(double(enc->memoryBytes())) + ", training texels " +
                  formatBytes(trainBytes) + ") but --memory-budget is " +
                  formatBytes(double(o.memoryBudget)));
    c.notice(
        format("streaming into codec %s: no raw BTF is written (raw size would be %s); "
               "encoder memory about %s",
               cs.codec.c_str(), formatBytes(double(btfFileBytes(info))).c_str(),
               formatBytes(double(enc->memoryBytes())).c_str()));
    job.setTrainingTexels(enc->trainingTexels(), [&](const float* v) { enc->train(v); });
    // The file carries the visibility map a store would: coded before the training texels, so
    // that a --target-ratio budget leaves its bytes out (on every rank: the same budget).
    CompressedBtf vmfOnly;
    job.setVmfSink([&](std::vector<float> v) {
      vmfOnly.info = info;
      vmfOnly.setVmf(v);
      enc->reserveBytes(vmfOnly.vmfCoded.size());
    });
    double encodeSeconds = 0;
    job.setChunkSink([&](int, int64_t t0, int64_t t1, const float* values) {
      const auto s0 = Clock::now();
      enc->add(t0, t1, values);
      c.ctx.check("encoder");
      encodeSeconds += since(s0);
    });
    const auto start = Clock::now();
    const uint64_t comm0 = comm.bytesSent() + comm.bytesReceived();
    const SimReport sr = job.run("", est, c.ctx.cancel);
    // A cluster job: each rank encoded the chunks it simulated; the encoder finishes over the
    // ranks and rank 0 writes.
    const auto f0 = Clock::now();
    CompressedBtf b;
    // finishOn holds collectives: a failure inside it is one rank's (btfsim then ends the job).
    b = enc->finishOn(comm);
    const double finishSeconds = since(f0);
    const uint64_t commBytes =
        comm.bytesSent() + comm.bytesReceived() - comm0 - sr.giShareBytes;
    if (comm.distributed())
      res.cluster = clusterFigures(comm, sr.texelsComputed, double(info.texelBytes()), commBytes,
                                   sr.rankEvalSeconds, sr.lightsSolved, sr.giShareBytes);
    if (!comm.root()) return;
    c.ctx.check("encoder");
    b.copyVmf(vmfOnly);
    writeCompressed(output, b);
    const double wall = since(start);
    const uint64_t rss = peakRssBytes();
    warnTarget(c, b);
    if (sr.adaptive) res.samples = json::parse(sr.samplingJson);
    SimulateResult::Compressed& z = res.compressed.emplace();
    z.file = codecFigures(b, double(info.texels()) * info.nDirs() * info.nDirs() * 12.0,
                          b.fileBytes(), b.ratio(), rss);
    z.wallSeconds = wall;
    z.simulateSeconds = sr.wallSeconds - encodeSeconds;
    z.encodeSeconds = encodeSeconds;
    z.finishSeconds = finishSeconds;
    c.rep.text =
        (res.cluster ? clusterText(*res.cluster) : std::string()) +
        format(
            "wrote %s\n  %d x %d texels, %d directions (%s); wall %s: simulation %s, "
            "encoding %s, finish (PCA) %s\n",
            output.c_str(), o.nu, o.nv, job.directions().size(), job.directions().name().c_str(),
            formatSeconds(wall).c_str(), formatSeconds(sr.wallSeconds - encodeSeconds).c_str(),
            formatSeconds(encodeSeconds).c_str(), formatSeconds(finishSeconds).c_str()) +
        samplingText(sr) + compressedText(b, wall, rss);
    c.rep.summary = format("wrote %s, ratio 1:%.0f in %s", output.c_str(), b.ratio(),
                           formatSeconds(wall).c_str());
    return;
  }
  const SimReport sr = job.run(output, est, c.ctx.cancel);
  if (!sr.resumeNote.empty()) c.warn(sr.resumeNote);
  if (comm.distributed())
    res.cluster =
        clusterFigures(comm, sr.texelsComputed, double(job.storeInfo(est.chunkTexels).texelBytes()),
                       sr.commBytes, sr.rankEvalSeconds, sr.lightsSolved, sr.giShareBytes);
  const double evalRate = sr.evalSeconds > 0 ? double(sr.abrdfValues) / sr.evalSeconds : 0;
  const double rayRate = sr.hitMapSeconds > 0 ? double(sr.hitMapRays) / sr.hitMapSeconds : 0;
  res.store = SimulateResult::Store{sr.networkPoints,    sr.networkLinks,   sr.precomputeSeconds,
                                    sr.renderSeconds,     sr.networkSeconds, sr.lightSeconds,
                                    sr.wallSeconds,       sr.hitMapSeconds,  sr.evalSeconds,
                                    sr.writeSeconds,      sr.hitMapRays,     rayRate,
                                    sr.abrdfValues,       evalRate,          sr.brdfEvaluations,
                                    sr.peakRssBytes,      sr.outputBytes,    sr.chunks,
                                    sr.chunksResumed,     sr.exactSeconds,
                                    sr.reciprocalSeconds, sr.reciprocalMaxCorrection,
                                    sr.networkReused};
  if (sr.adaptive) res.samples = json::parse(sr.samplingJson);
  const EffectPlan& pl = job.plan();
  std::string t =
      format("wrote %s (%s)\n", output.c_str(), formatBytes(double(sr.outputBytes)).c_str());
  t += format("  %d x %d texels, %d directions (%s), sampling %s, shadows %s, %d thread(s)\n", o.nu,
              o.nv, job.directions().size(), job.directions().name().c_str(),
              samplingName(job).c_str(),
              o.method == "pt" ? "exact (path traced)" : shadowModeName(o.shadows), est.threads);
  t += samplingText(sr);
  std::string parts;
  if (sr.exactSeconds > 0) parts += "exact visibility " + formatSeconds(sr.exactSeconds) + ", ";
  if (sr.reciprocalSeconds > 0)
    parts += format("reciprocal gather %s (corrections up to %.1f %%), ",
                    formatSeconds(sr.reciprocalSeconds).c_str(), 100 * sr.reciprocalMaxCorrection);
  t += format("  wall %s: hit maps %s (%.2f M rays/s), %saBRDF %s (%.2f M values/s), write %s\n",
              formatSeconds(sr.wallSeconds).c_str(), formatSeconds(sr.hitMapSeconds).c_str(),
              rayRate / 1e6, parts.c_str(), formatSeconds(sr.evalSeconds).c_str(), evalRate / 1e6,
              formatSeconds(sr.writeSeconds).c_str());
  t += format("  effects: self-shadowing %s, inter-reflection %s (P = %d), %d channel(s), VMF %s\n",
              pl.selfShadowing ? "on" : "off", pl.interreflection ? "on" : "off", pl.bounces,
              pl.channels, pl.vmf ? "on" : "off");
  if (sr.networkPoints)
    t += format(
        "  precompute %s (network %s: %zu points, %zu links; hit maps %s), render %s "
        "(network light %s)\n",
        formatSeconds(sr.precomputeSeconds).c_str(),
        sr.networkReused ? "reused" : formatSeconds(sr.networkSeconds).c_str(),
        sr.networkPoints, sr.networkLinks, formatSeconds(sr.hitMapSeconds).c_str(),
        formatSeconds(sr.renderSeconds).c_str(), formatSeconds(sr.lightSeconds).c_str());
  t += format("  peak memory %s; chunks %d (%d resumed)\n",
              formatBytes(double(sr.peakRssBytes)).c_str(), sr.chunks, sr.chunksResumed);
  if (res.cluster) t += clusterText(*res.cluster);
  c.rep.text = t;
  c.rep.summary =
      format("wrote %s (%s) in %s", output.c_str(), formatBytes(double(sr.outputBytes)).c_str(),
             formatSeconds(sr.wallSeconds).c_str()) +
      (sr.chunksResumed ? format(", %d chunk(s) resumed", sr.chunksResumed) : "");
}

void plan(const Call& c) {
  const Scene scene = c.scene();
  SimOptions o = simOptions(scene, c.r);
  o.progress = false;
  SimulationJob job(scene, o);
  job.setCancel(c.ctx.cancel);
  const SimEstimate est = job.estimate("");
  const EffectPlan& p = job.plan();
  PlanResult& res = c.rep.result.emplace<PlanResult>();
  res.plan = planJson(p);
  res.scene = scene.name;
  res.method = o.method;
  res.nu = o.nu, res.nv = o.nv;
  res.directions = job.directions().name();
  res.triangles = job.geometry().triangleCount();
  res.estimate = {est.seconds,      est.hitMapSeconds, est.evalSeconds, est.lightSeconds,
                  est.gatherSeconds, est.memoryBytes,   est.networkBytes};
  if (const PointNetwork* n = job.network())
    res.network = PlanResult::Network{n->points().size(), n->links().size(), n->settings().voxels,
                                      n->buildSeconds()};
  std::string t = format("effect plan for %s (%dx%d texels, %s, %d directions, method %s):\n",
                         scene.name.c_str(), o.nu, o.nv, job.directions().name().c_str(),
                         job.directions().size(), o.method.c_str());
  t += planText(p);
  t += format("geometry: %zu triangles (%zu in the tracer with the periodic copies)\n",
              job.geometry().triangleCount(), job.tracer().embreeTriangles());
  t += format(
      "analysis: %s; ρ_max %.3g; α max %.3g, mean %.3g; %lld of %lld occlusion probes "
      "occluded\n",
      p.flat ? "flat tile" : "relief", p.rhoMax, p.alphaMax, p.alphaMean,
      (long long)p.occludedTests, (long long)p.occlusionTests);
  if (const PointNetwork* n = job.network())
    t += format("point network: %zu points, %zu links (%d voxels per side), built in %s\n",
                n->points().size(), n->links().size(), n->settings().voxels,
                formatSeconds(n->buildSeconds()).c_str());
  t += format(
      "estimate: %s (hit maps %s, aBRDF %s of which final gather %s, network light %s) "
      "on %d thread(s); memory %s\n",
      formatSeconds(est.seconds).c_str(), formatSeconds(est.hitMapSeconds).c_str(),
      formatSeconds(est.evalSeconds).c_str(), formatSeconds(est.gatherSeconds).c_str(),
      formatSeconds(est.lightSeconds).c_str(), est.threads,
      formatBytes(double(est.memoryBytes)).c_str());
  c.rep.text = t;
  c.rep.summary = "plan of " + scene.name + ": estimate " + formatSeconds(est.seconds);
}

void bench(const Call& c) {
  const Scene scene = c.scene();
  BenchResult& res = c.rep.result.emplace<BenchResult>();
  res.scene = scene.name;
  std::string t;
  for (const auto& mode : splitList(c.r.s("shadows"), "--shadows")) {
    SimOptions o = simOptions(scene, c.r);
    o.shadows = parseShadowMode(mode);
    o.progress = false;
    o.memoryBudget = uint64_t(2) << 30;
    SimulationJob job(scene, o);
    job.setCancel(c.ctx.cancel);
    const SimEstimate est = job.estimate("");
    std::vector<double> wall, hit, eval, rays, rates, rss;
    SimReport last;
    const int repeat = c.r.i("repeat");
    for (int k = 0; k < repeat; ++k) {
      const SimReport sr = job.run("", est, c.ctx.cancel);
      wall.push_back(sr.wallSeconds);
      hit.push_back(sr.hitMapSeconds);
      eval.push_back(sr.evalSeconds);
      rays.push_back(double(sr.hitMapRays) / std::max(1e-9, sr.hitMapSeconds));
      rates.push_back(double(sr.abrdfValues) / std::max(1e-9, sr.evalSeconds));
      rss.push_back(double(sr.peakRssBytes));
      last = sr;
      c.notice(
          format("bench %s run %d/%d: %.2f s (hit maps %.2f s, aBRDF %.2f s, %.1f M "
                 "values/s; P = %d)",
                 mode.c_str(), k + 1, repeat, sr.wallSeconds, sr.hitMapSeconds, sr.evalSeconds,
                 rates.back() / 1e6, job.plan().bounces));
    }
    auto median = [](std::vector<double> v) {
      std::sort(v.begin(), v.end());
      return v[v.size() / 2];
    };
    const double peak = *std::max_element(rss.begin(), rss.end());
    BenchResult::Mode j;
    j.shadows = mode;
    j.method = o.method;
    j.interreflection = job.plan().interreflection;
    j.bounces = job.plan().bounces;
    j.nu = o.nu, j.nv = o.nv;
    j.directions = job.directions().name();
    j.pairs = int64_t(job.directions().size()) * job.directions().size();
    j.spp = o.spp;
    j.sampling = samplingName(job);
    if (last.adaptive) j.samples = json::parse(last.samplingJson);
    j.threads = est.threads;
    j.runs = repeat;
    j.medianWallSeconds = median(wall);
    j.medianHitMapSeconds = median(hit);
    j.medianAbrdfSeconds = median(eval);
    j.medianRaysPerSecond = median(rays);
    j.medianAbrdfValuesPerSecond = median(rates);
    j.estimatedSeconds = est.seconds;
    j.peakRssBytes = peak;
    j.memoryBudgetBytes = o.memoryBudget;
    res.results.push_back(std::move(j));
    t += format(
        "%-5s %dx%d texels x %s^2, %s, %d thread(s): median wall %.2f s = hit maps "
        "%.2f s (%.2f M rays/s) + aBRDF %.2f s (%.1f M values/s); peak RSS %s\n",
        mode.c_str(), o.nu, o.nv, job.directions().name().c_str(), samplingName(job).c_str(),
        est.threads, median(wall), median(hit), median(rays) / 1e6, median(eval),
        median(rates) / 1e6, formatBytes(peak).c_str());
    t += samplingText(last);
  }
  c.rep.text = t;
  c.rep.summary = "bench of " + scene.name;
}

namespace {

std::vector<DirectionPair> readPairs(const Request& r, std::vector<std::array<double, 4>>* deg) {
  std::vector<DirectionPair> pairs;
  std::stringstream list(r.s("pair"));
  std::string item;
  while (std::getline(list, item, ';'))
    if (!item.empty()) {
      std::array<double, 4> v;
      pairs.push_back(parsePairText(item, "--pair", &v));
      deg->push_back(v);
    }
  const std::string& file = r.s("pairs");
  if (!file.empty()) {
    checkInputFile(file, "pairs file", uint64_t(64) << 20, "64 MiB");
    std::ifstream f(file, std::ios::binary);
    if (!f) throw Error(file + ": cannot open pairs file");
    std::stringstream ss;
    ss << f.rdbuf();
    const auto more = parsePairsFile(ss.str(), file, deg);
    pairs.insert(pairs.end(), more.begin(), more.end());
  }
  if (pairs.empty()) throw Error("no direction pairs: give --pair θi,φi,θo,φo or --pairs FILE.csv");
  return pairs;
}

}  // namespace

void brdf(const Call& c) {
  const Request& r = c.r;
  const Scene scene = c.scene();
  std::vector<std::array<double, 4>> deg;
  const auto pairs = readPairs(r, &deg);
  SimOptions o = optionsFromScene(scene);
  o.progress = false;
  SimulationJob job(scene, o);
  const int samples = r.i("spp");
  std::vector<Rgb> vals;
  if (r.s("method") == "direct") {
    vals = averagedBrdf(job.tracer(), job.materials(), pairs, samples, o.seed);
  } else {
    PathSettings ps;
    ps.maxBounces = r.i("bounces");
    ps.seed = o.seed;
    vals = pathTracedBrdf(job.tracer(), job.materials(), pairs, samples, r.i("paths"), ps);
  }
  BrdfResult& res = c.rep.result.emplace<BrdfResult>();
  std::string t = "theta_i,phi_i,theta_o,phi_o,r,g,b\n";
  for (size_t k = 0; k < vals.size(); ++k) {
    res.pairs.push_back(
        {deg[k][0], deg[k][1], deg[k][2], deg[k][3], {vals[k].x, vals[k].y, vals[k].z}});
    t += format("%g,%g,%g,%g,%.7g,%.7g,%.7g\n", deg[k][0], deg[k][1], deg[k][2], deg[k][3],
                vals[k].x, vals[k].y, vals[k].z);
  }
  res.scene = scene.name;
  res.method = r.s("method");
  res.bounces = r.i("bounces");
  res.samples = samples * samples * (r.s("method") == "pt" ? r.i("paths") : 1);
  c.rep.text = t;
  c.rep.summary = format("%zu pair(s) of %s", vals.size(), scene.name.c_str());
}

}  // namespace btf::ops::detail
