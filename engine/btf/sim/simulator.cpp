#include <btf/core/error.h>
#include <btf/core/hash.h>
#include <btf/core/sysinfo.h>
#include <btf/geometry/tile_builder.h>
#include <btf/sim/simulator.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>

namespace btf {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
int activeThreads() {
  return int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}
}  // namespace

SimOptions optionsFromScene(const Scene& scene) {
  SimOptions o;
  const ParamSet& s = scene.simulation;
  o.nu = s.i2("texels")[0];
  o.nv = s.i2("texels")[1];
  o.directions = s.s("directions") == "grid"
                     ? std::to_string(s.i2("grid")[0]) + "x" + std::to_string(s.i2("grid")[1])
                     : s.s("directions");
  o.spp = s.i("spp");
  o.shadows = parseShadowMode(s.s("shadows"));
  o.seed = uint64_t(s.i("seed"));
  return o;
}

SimulationJob::SimulationJob(const Scene& scene, SimOptions options)
    : m_scene(scene), m_opt(std::move(options)) {
  if (m_opt.nu < 1 || m_opt.nv < 1 || m_opt.nu > 16384 || m_opt.nv > 16384)
    throw Error("invalid texel resolution " + std::to_string(m_opt.nu) + "x" +
                std::to_string(m_opt.nv) + ": each must be between 1 and 16384");
  if (m_opt.spp < 1 || m_opt.spp > 64)
    throw Error("invalid --spp " + std::to_string(m_opt.spp) + ": must be 1..64");
  if (!(m_opt.shadowBias >= 0) || !std::isfinite(m_opt.shadowBias))
    throw Error("shadow bias must be a finite number >= 0");
  enableFlushToZeroOnWorkers();
  m_dirs = DirectionSet::fromName(m_opt.directions);
  m_geom = buildTileGeometry(m_scene);
  m_tracer = std::make_unique<PeriodicTracer>(m_geom);
  m_materials = compileMaterials(m_scene);
}

SimulationJob::~SimulationJob() = default;

std::string SimulationJob::sceneHash() const {
  return hex64(checksum64(sceneToJson(m_scene), m_geom.checksum()));
}

BtfInfo SimulationJob::storeInfo(int chunkTexels) const {
  BtfInfo i;
  i.nu = m_opt.nu;
  i.nv = m_opt.nv;
  i.Lx = m_scene.Lx;
  i.Ly = m_scene.Ly;
  i.directionSet = m_dirs.name();
  for (const auto& d : m_dirs.dirs()) i.dirsDeg.push_back({rad2deg(d.theta), rad2deg(d.phi)});
  i.chunkTexels = chunkTexels;
  i.spp = m_opt.spp;
  i.shadows = shadowModeName(m_opt.shadows);
  i.shadowBias = m_opt.shadowBias;
  i.seed = m_opt.seed;
  i.sceneName = m_scene.name;
  i.sceneHash = sceneHash();
  i.sceneJson = sceneToJson(m_scene);
  nlohmann::ordered_json plan;
  plan["effects"]["direct"] = true;
  plan["effects"]["self_shadowing"] = shadowModeName(m_opt.shadows);
  plan["effects"]["interreflection"] = false;
  plan["note"] =
      "direct illumination with self-shadowing and masking; global illumination is not simulated "
      "by this build";
  i.plan = plan.dump();
  return i;
}

SimEstimate SimulationJob::estimate(const std::string& outPath) const {
  SimEstimate e;
  e.threads = activeThreads();
  const int nD = m_dirs.size();
  const int64_t texels = int64_t(m_opt.nu) * m_opt.nv;
  const uint64_t samples = uint64_t(texels) * uint64_t(m_opt.spp) * uint64_t(m_opt.spp);
  BtfInfo probe = storeInfo(1);
  const uint64_t texelBytes = probe.texelBytes();
  e.hitMapBytes = uint64_t(nD) * samples * HitMaps::kBytesPerSample;
  const uint64_t vmfBytes = uint64_t(nD) * uint64_t(texels) * 8;
  const uint64_t fixed =
      (64ull << 20) + e.hitMapBytes + vmfBytes + m_tracer->embreeTriangles() * 160;
  if (fixed + texelBytes > m_opt.memoryBudget) {
    e.refusal = "memory budget " + formatBytes(double(m_opt.memoryBudget)) +
                " is too small: hit maps need " + formatBytes(double(e.hitMapBytes)) +
                ", visibility map " + formatBytes(double(vmfBytes)) + ", one texel's " +
                std::to_string(nD) + "x" + std::to_string(nD) + " matrix " +
                formatBytes(double(texelBytes)) +
                " (lower --texels, --spp or the direction count, or raise --memory-budget)";
  }
  uint64_t perChunk = std::max<uint64_t>(
      1, (m_opt.memoryBudget > fixed ? m_opt.memoryBudget - fixed : 0) / texelBytes);
  perChunk = std::min<uint64_t>(perChunk, std::max<uint64_t>(1, m_opt.maxChunkBytes / texelBytes));
  perChunk = std::min<uint64_t>(perChunk, uint64_t(texels));
  e.chunkTexels = int(perChunk);
  e.chunkBytes = perChunk * texelBytes;
  e.memoryBytes = fixed + e.chunkBytes;
  BtfInfo info = storeInfo(e.chunkTexels);
  e.chunks = info.chunks();
  e.diskBytes = outPath.empty() ? 0 : btfFileBytes(info);
  if (!outPath.empty()) {
    e.freeDiskBytes = freeDiskBytes(outPath);
    if (e.refusal.empty() && e.freeDiskBytes > 0 && e.diskBytes > e.freeDiskBytes)
      e.refusal = "not enough disk space for " + outPath + ": needs " +
                  formatBytes(double(e.diskBytes)) + ", " + formatBytes(double(e.freeDiskBytes)) +
                  " free";
  }

  // Time: calibrate on this scene — hit maps and the direct kernel on a coarse 8×8 grid with the
  // same directions, materials and shadow mode; cost per (sample, view) scales with nL.
  const int cal = 8;
  SampleGrid g{cal, cal, 1, m_scene.Lx, m_scene.Ly, m_opt.seed};
  HitMaps maps;
  auto t0 = Clock::now();
  {
    ThreadLimit one(1);
    maps.build(*m_tracer, m_dirs, g);
  }
  const double perRay = since(t0) / double(maps.raysTraced());
  DirectIllumination direct(*m_tracer, m_materials, m_dirs, maps,
                            {m_opt.shadows, m_opt.shadowBias});
  std::vector<float> buf(size_t(nD) * 3);
  const int calls = std::min(64, nD * 4);
  t0 = Clock::now();
  for (int k = 0; k < calls; ++k)
    direct.evalTexelView(k % cal, (k / cal) % cal, (k * 7) % nD, buf.data());
  const double perSampleView = since(t0) / calls;
  const double threads = std::max(1, e.threads);
  e.hitMapSeconds = double(nD) * double(samples) * perRay / threads;
  e.evalSeconds = double(samples) * double(nD) * perSampleView / threads;
  e.seconds = e.hitMapSeconds + e.evalSeconds;
  return e;
}

SimReport SimulationJob::run(const std::string& outPath, const SimEstimate& est,
                             const CancelToken* cancel) {
  if (!est.refusal.empty()) throw Error(est.refusal);
  SimReport r;
  r.output = outPath;
  const auto start = Clock::now();
  const BtfInfo info = storeInfo(est.chunkTexels);
  std::unique_ptr<BtfWriter> writer;
  if (!outPath.empty()) writer = std::make_unique<BtfWriter>(outPath, info, m_opt.resume);
  r.chunks = info.chunks();
  r.chunksResumed = writer ? writer->chunksDone() : 0;

  SampleGrid grid{m_opt.nu, m_opt.nv, m_opt.spp, m_scene.Lx, m_scene.Ly, m_opt.seed};
  HitMaps maps;
  {
    ProgressReporter pr("hit maps", m_dirs.size(), m_opt.progress);
    maps.build(*m_tracer, m_dirs, grid, &pr, cancel);
    pr.finish();
  }
  r.hitMapSeconds = since(start);
  r.hitMapRays = maps.raysTraced();
  if (cancel && cancel->cancelled()) {
    r.cancelled = true;
    return r;
  }
  const int nD = m_dirs.size();
  if (writer) {
    std::vector<float> vmf;
    vmf.reserve(size_t(nD) * size_t(info.texels()) * 2);
    for (int d = 0; d < nD; ++d) {
      auto v = maps.vmf(d);
      vmf.insert(vmf.end(), v.begin(), v.end());
    }
    writer->writeVmf(vmf);
  }

  DirectIllumination direct(*m_tracer, m_materials, m_dirs, maps,
                            {m_opt.shadows, m_opt.shadowBias});
  const char* abortEnv = std::getenv("BTF_TEST_ABORT_AFTER_CHUNKS");  // test hook: simulates a kill
  const int abortAfter = abortEnv ? std::atoi(abortEnv) : -1;
  int written = 0;
  std::vector<float> chunk;
  std::atomic<uint64_t> evals{0};
  ProgressReporter pr("aBRDF", info.texels(), m_opt.progress);
  const auto evalStart = Clock::now();
  for (int c = 0; c < info.chunks(); ++c) {
    const int64_t t0 = info.chunkBegin(c), t1 = info.chunkEnd(c);
    if (writer && writer->chunkDone(c)) {
      pr.add(t1 - t0);
      continue;
    }
    const size_t stride = size_t(nD) * size_t(nD) * 3;
    chunk.assign(size_t(t1 - t0) * stride, 0.f);
    parallelForChunks((t1 - t0) * nD, 8,
                      [&](int64_t b, int64_t e) {
                        uint64_t local = 0;
                        for (int64_t k = b; k < e; ++k) {
                          const int64_t t = t0 + k / nD;
                          const int view = int(k % nD);
                          local += uint64_t(direct.evalTexelView(
                              int(t % m_opt.nu), int(t / m_opt.nu), view,
                              &chunk[size_t(k / nD) * stride + size_t(view) * nD * 3]));
                          if (view == nD - 1) pr.add(1);
                        }
                        evals += local;
                      },
                      cancel);
    if (cancel && cancel->cancelled()) {
      r.cancelled = true;
      break;
    }
    r.abrdfValues += uint64_t(t1 - t0) * uint64_t(nD) * uint64_t(nD);
    if (writer) {
      const auto w0 = Clock::now();
      writer->writeChunk(c, chunk.data());
      r.writeSeconds += since(w0);
      if (++written == abortAfter) {
        std::fprintf(stderr, "\nBTF_TEST_ABORT_AFTER_CHUNKS: exiting abruptly after %d chunk(s)\n",
                     written);
        std::_Exit(75);
      }
    }
  }
  if (!r.cancelled) pr.finish();
  r.evalSeconds = since(evalStart) - r.writeSeconds;
  r.brdfEvaluations = evals.load();
  if (writer && !r.cancelled) {
    writer->finish();
    r.outputBytes = btfFileBytes(info);
  }
  r.wallSeconds = since(start);
  r.peakRssBytes = peakRssBytes();
  return r;
}

}  // namespace btf
