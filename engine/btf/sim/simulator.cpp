#include <btf/core/error.h>
#include <btf/core/hash.h>
#include <btf/core/run_context.h>
#include <btf/core/sysinfo.h>
#include <btf/geometry/tile_builder.h>
#include <btf/sim/path_tracer.h>
#include <btf/sim/shading.h>
#include <btf/sim/simulator.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <future>
#include <nlohmann/json.hpp>

namespace btf {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
}  // namespace

SimOptions optionsFromScene(const Scene& scene) {
  SimOptions o;
  const ParamSet& s = scene.simulation;
  o.nu = s.i2("texels")[0];
  o.nv = s.i2("texels")[1];
  const std::string counts =
      std::to_string(s.i2("grid")[0]) + "x" + std::to_string(s.i2("grid")[1]);
  o.directions = s.s("directions") == "grid"        ? counts
                 : s.s("directions") == "axis-grid" ? counts + "a"
                                                    : s.s("directions");
  o.spp = s.i("spp");
  o.adaptive = s.s("sampling") == "adaptive";
  o.adaptiveSettings.maxK = s.i("max_spp");
  o.shadows = parseShadowMode(s.s("shadows"));
  o.seed = uint64_t(s.i("seed"));
  o.method = s.s("method");
  o.plan.interreflection = parseToggle(s.s("interreflection"), "simulation.interreflection");
  o.plan.bounces = s.i("bounces");
  if (o.plan.bounces == 1) o.plan.interreflection = Toggle::Off;
  if (o.plan.bounces > 1 && o.plan.interreflection == Toggle::Auto)
    o.plan.interreflection = Toggle::On;
  if (s.i("network_voxels") == 1)
    throw Error("simulation.network_voxels: must be 0 (auto) or at least 2");
  o.network.voxels = s.i("network_voxels");
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
  if (m_opt.method != "network" && m_opt.method != "pt")
    throw Error("unknown --method '" + m_opt.method + "' (expected network or pt)");
  if (m_opt.ptPaths < 1 || m_opt.ptPaths > 65536)
    throw Error("invalid --paths " + std::to_string(m_opt.ptPaths) + ": must be 1..65536");
  if (m_opt.shadows == ShadowMode::None)
    throw Error("shadow mode 'none' is the planner's choice: use --self-shadowing off");
  enableFlushToZeroOnWorkers();
  m_dirs = DirectionSet::fromName(m_opt.directions);
  m_geom = buildTileGeometry(m_scene, m_opt.memoryBudget);
  m_tracer = std::make_unique<PeriodicTracer>(m_geom);
  m_materials = compileMaterials(m_scene);
  m_adaptive = m_opt.adaptive && m_opt.method != "pt";
  m_mapSpp = m_opt.spp;
  if (m_adaptive) {
    const int maxK = m_opt.adaptiveSettings.maxK;
    if (adaptiveLevel(maxK) < 0)
      throw Error("invalid --max-spp " + std::to_string(maxK) +
                  ": must be a power of two in 2..64");
    if (!(m_opt.adaptiveSettings.tolerance > 0) || !(m_opt.adaptiveSettings.tolerance <= 1))
      throw Error("invalid --tolerance: must be in (0, 1]");
    // 4×4 map samples per texel: level 1 of the refinement costs no ray and the shadow maps are
    // twice as fine; 2×2 when the maps would take more than half the memory budget.
    m_mapSpp = std::min(4, maxK);
    const uint64_t mapBytes = uint64_t(m_dirs.size()) * uint64_t(m_opt.nu) * uint64_t(m_opt.nv) *
                              16u * (HitMaps::kBytesPerSample + HitMaps::kEdgeBytesPerSample);
    if (m_mapSpp == 4 && mapBytes > m_opt.memoryBudget / 2) m_mapSpp = 2;
  }
}

SimulationJob::~SimulationJob() = default;

std::string SimulationJob::sceneHash() const {
  return hex64(checksum64(sceneToJson(m_scene), m_geom.checksum()));
}

NetworkSettings SimulationJob::networkSettings() const {
  NetworkSettings n = m_opt.network;
  if (n.voxels == 0) n.voxels = std::clamp(std::max(m_opt.nu, m_opt.nv), 64, 128);
  n.seed = m_opt.seed;
  return n;
}

void SimulationJob::checkCancel() const {
  throwIfCancelled(m_cancel, "simulation set-up");
}

const EffectPlan& SimulationJob::plan() const {
  if (!m_plan) {
    if (m_opt.plan.interreflection != Toggle::Off) {
      m_network = std::make_unique<PointNetwork>();
      std::unique_ptr<ProgressReporter> pr;
      m_network->build(*m_tracer, networkSettings(), nullptr, m_cancel);
      checkCancel();
    }
    m_plan = std::make_unique<EffectPlan>(
        planEffects(*m_tracer, m_materials, m_dirs, m_network.get(), m_opt.plan));
    if (m_plan->selfShadowing && m_opt.shadows == ShadowMode::Map && m_opt.method != "pt") {
      // Where the shadow map cannot be trusted, exact rays take over (docs/conventions.md).
      int grazing = 0;
      for (const auto& d : m_dirs.dirs()) grazing += rad2deg(d.theta) >= m_opt.grazingRays - 1e-9;
      char value[32], reason[256];
      std::snprintf(value, sizeof value, grazing ? "θ≥%g°" : "none", m_opt.grazingRays);
      std::snprintf(reason, sizeof reason,
                    "%d of %d lights at θi ≥ %g° use exact shadow rays: the map's bias and filter "
                    "leak light at grazing incidence (box cavity +5 %% albedo at 76–87°)",
                    grazing, m_dirs.size(), m_opt.grazingRays);
      m_plan->decisions.push_back({"grazing_rays", value, reason, m_opt.grazingRaysForced, 0});
    }
    if (m_adaptive) {
      char value[32], reason[256];
      const int K = m_opt.adaptiveSettings.maxK;
      std::snprintf(value, sizeof value, "≤%dx%d", K, K);
      std::snprintf(reason, sizeof reason,
                    "adaptive: 2x2 samples per texel, up to %dx%d where samples disagree (edges, "
                    "shadow boundaries; tolerance %g %%); hit maps %dx%d per texel",
                    K, K, 100.0 * m_opt.adaptiveSettings.tolerance, m_mapSpp, m_mapSpp);
      m_plan->decisions.push_back({"sampling", value, reason, false, 0});
    }
  }
  return *m_plan;
}

const PointNetwork* SimulationJob::network() const {
  plan();
  return m_network.get();
}

namespace {
bool anyGlossy(const std::vector<Material>& mats) {
  for (const Material& m : mats)
    if (m.type != BrdfType::Lambert && (m.ks.x > 0 || m.ks.y > 0 || m.ks.z > 0)) return true;
  return false;
}
}  // namespace

GlossyGather SimulationJob::glossyGather() const {
  if (!anyGlossy(m_materials) || !m_network || !plan().glossyIndirect) return GlossyGather::None;
  // Exact per-link gathering when its table (links × lights × RGB) fits in an eighth of the
  // memory budget and 512 MiB; the mean incident direction otherwise.
  const uint64_t bytes = uint64_t(m_network->links().size()) * uint64_t(m_dirs.size()) * 12;
  return bytes <= std::min<uint64_t>(m_opt.memoryBudget / 8, uint64_t(512) << 20)
             ? GlossyGather::Links
             : GlossyGather::MeanDirection;
}

BtfInfo SimulationJob::storeInfo(int chunkTexels) const {
  BtfInfo i;
  i.nu = m_opt.nu;
  i.nv = m_opt.nv;
  i.Lx = m_scene.Lx;
  i.Ly = m_scene.Ly;
  i.directionSet = m_dirs.name();
  // Degrees rounded to 1e-9: the sets' angles are stored as declared (15, not 14.999999999999998).
  auto exactDeg = [](double rad) { return std::round(rad2deg(rad) * 1e9) / 1e9; };
  for (const auto& d : m_dirs.dirs()) i.dirsDeg.push_back({exactDeg(d.theta), exactDeg(d.phi)});
  i.chunkTexels = chunkTexels;
  i.spp = m_mapSpp;
  const EffectPlan& pl = plan();
  i.shadows = m_opt.method == "pt" ? "exact (path traced)"
              : pl.selfShadowing   ? shadowModeName(m_opt.shadows)
                                   : shadowModeName(ShadowMode::None);
  i.hasVmf = pl.vmf;
  i.shadowBias = m_opt.shadowBias;
  i.seed = m_opt.seed;
  i.sceneName = m_scene.name;
  i.sceneHash = sceneHash();
  i.sceneJson = sceneToJson(m_scene);
  nlohmann::ordered_json plan = nlohmann::ordered_json::parse(pl.toJson(false));
  plan["method"] = m_opt.method;
  if (m_adaptive)
    plan["sampling"] = {{"mode", "adaptive"},
                        {"base", 2},
                        {"max", m_opt.adaptiveSettings.maxK},
                        {"map", m_mapSpp},
                        {"tolerance", m_opt.adaptiveSettings.tolerance},
                        {"edge_cells", m_opt.adaptiveSettings.edgeCells}};
  else
    plan["sampling"] = {{"mode", "uniform"}, {"spp", m_opt.spp}};
  if (m_opt.method == "pt") plan["pt_paths_per_sample"] = m_opt.ptPaths;
  if (m_opt.method == "network" && pl.interreflection) {
    const NetworkSettings n = networkSettings();
    plan["network"]["voxels"] = n.voxels;
    plan["network"]["min_distance"] = n.minDistance;
    plan["network"]["alpha_directions"] = n.alphaDirections;
    plan["network"]["links"] = n.links;
    plan["network"]["gather"] = n.gather;
    plan["network"]["gather_occlusion_rays"] = n.gatherOcclusion;
    plan["network"]["glossy_gather"] = glossyGatherName(glossyGather());
    plan["network"]["points"] = m_network->points().size();
    plan["network"]["link_count"] = m_network->links().size();
  }
  i.plan = plan.dump();
  return i;
}

namespace {

// Everything that evaluates one (texel, view) row of lights: the direct kernel, the network's
// final gather, or the path tracer.
struct TexelKernel {
  const PeriodicTracer& tracer;
  const std::vector<Material>& materials;
  const DirectionSet& dirs;
  const HitMaps& maps;
  const DirectIllumination& direct;
  const NetworkGather* gather = nullptr;
  bool pathTrace = false;
  const AdaptiveTexelSampler* adaptive = nullptr;
  PathSettings pt;
  int ptPaths = 1;
  std::vector<DVec3> lights;

  /// Texels evaluated together per (block, view) item: the plain direct kernel lights a block
  /// light by light (DirectIllumination::evalTexelsView); the other kernels go texel by texel.
  int blockTexels() const { return adaptive || pathTrace ? 1 : DirectIllumination::kBlockTexels; }

  /// Texels t0 … t0 + count − 1 (row-major over nu columns) seen from `view`: texel k's row of
  /// lights at out + k · stride. Every value equals eval's.
  int64_t evalBlock(int64_t t0, int count, int nu, int view, float* out, size_t stride) const {
    BTF_CHECK(count >= 1 && count <= blockTexels());
    if (count == 1) {
      int64_t n = 0;
      for (int k = 0; k < count; ++k)
        n += eval(int((t0 + k) % nu), int((t0 + k) / nu), view, out + size_t(k) * stride);
      return n;
    }
    // count ≤ kBlockTexels: one block.
    int ti[DirectIllumination::kBlockTexels], tj[DirectIllumination::kBlockTexels];
    float* rows[DirectIllumination::kBlockTexels];
    for (int k = 0; k < count; ++k) {
      ti[k] = int((t0 + k) % nu), tj[k] = int((t0 + k) / nu);
      rows[k] = out + size_t(k) * stride;
    }
    const int64_t n = direct.evalTexelsView(ti, tj, count, view, rows);
    if (gather)
      for (int k = 0; k < count; ++k) addGather(ti[k], tj[k], view, rows[k]);
    return n;
  }

  int64_t eval(int i, int j, int view, float* out) const {
    const int nL = dirs.size();
    const SampleGrid& g = maps.grid();
    const int K2 = g.spp * g.spp;
    if (adaptive && !pathTrace) return adaptive->eval(i, j, view, out);
    if (pathTrace) {
      std::vector<Rgb> acc(size_t(nL), Rgb(0));
      const float w = 1.0f / (float(K2) * float(ptPaths));
      for (int s = 0; s < K2; ++s) {
        const int64_t si = g.sampleIndex(i, j, s);
        const DVec3 p0 = g.position(int(si % g.su()), int(si / g.su()));
        for (int q = 0; q < ptPaths; ++q) {
          Rng rng(hashKeys(pt.seed ^ 0x7e11, uint64_t(si), uint64_t(view), uint64_t(q)));
          tracePath(tracer, materials, p0, dirs[view].w, lights.data(), nL, pt, rng, w, acc.data());
        }
      }
      for (int l = 0; l < nL; ++l)
        for (int c = 0; c < 3; ++c) out[3 * l + c] = std::isfinite(acc[l][c]) ? acc[l][c] : 0.f;
      return int64_t(K2) * ptPaths * nL;
    }
    const int64_t n = direct.evalTexelView(i, j, view, out);
    if (gather) addGather(i, j, view, out);
    return n;
  }

  // The network's final gather at texel (i, j)'s samples, added to its row.
  void addGather(int i, int j, int view, float* out) const {
    const SampleGrid& g = maps.grid();
    const int K2 = g.spp * g.spp;
    const DVec3 wv = dirs[view].w;
    const float invK2 = 1.0f / float(K2);
    const TileGeometry& geom = tracer.geometry();
    for (int s = 0; s < K2; ++s) {
      const int64_t si = g.sampleIndex(i, j, s);
      const uint32_t prim = maps.prim(view, si);
      if (prim == kNoHit) continue;
      const DVec3 p0 = g.position(int(si % g.su()), int(si / g.su()));
      const Vec3 p = Vec3(p0 + double(maps.depth(view, si)) * wv);
      Vec3 ng, ns;
      if (!hitNormals(geom, prim, maps.bu(view, si), maps.bv(view, si), Vec3(wv), &ng, &ns))
        continue;
      gather->add(p, ng, ns, prim, Vec3(wv), invK2, out);
    }
  }
};

// A cluster job's unit of work (docs/cluster.md): a whole chunk, or views [v0, v1) of a chunk
// when fewer chunks are missing than twice the ranks.
struct ViewPiece {
  int chunk = 0, v0 = 0, v1 = 0;
};
struct SplitChunk {
  int chunk = 0, owner = 0;  // owner: the rank of its first piece; it writes the chunk
};

// Every rank computes the same assignment from the same maps and done flags.
void assignWork(const BtfInfo& info, const HitMaps& maps, int nu, int nD, const BtfWriter* writer,
                const Comm& comm, std::vector<uint8_t>& mine, std::vector<ViewPiece>& pieces,
                std::vector<SplitChunk>& splits) {
  const int K = maps.grid().spp;
  struct Work {
    double cost;
    ViewPiece p;
  };
  std::vector<std::vector<double>> viewCost;  // per missing chunk, per view
  std::vector<int> missing;
  for (int c = 0; c < info.chunks(); ++c) {
    mine[size_t(c)] = 0;
    if (writer && writer->chunkDone(c)) continue;
    std::vector<double> w(size_t(nD), 0.0);
    for (int64_t t = info.chunkBegin(c); t < info.chunkEnd(c); ++t) {
      const int i = int(t % nu), j = int(t / nu);
      for (int d = 0; d < nD; ++d)
        w[size_t(d)] +=
            maps.hasEdgeTables() && maps.edgeCount(d, i * K, (i + 1) * K, j * K, (j + 1) * K) ? 5.0
                                                                                              : 1.0;
    }
    missing.push_back(c);
    viewCost.push_back(std::move(w));
  }
  const int R = comm.size(), M = int(missing.size());
  // Pieces per chunk: enough for about four per rank when the chunks alone are too few.
  const int P = M > 0 && M < 2 * R ? std::min(nD, (4 * R + M - 1) / M) : 1;
  std::vector<Work> work;
  for (int m = 0; m < M; ++m) {
    const std::vector<double>& w = viewCost[size_t(m)];
    double total = 0;
    for (double x : w) total += x;
    // Contiguous view ranges of about equal cost, none empty.
    int v0 = 0;
    double acc = 0;
    for (int k = 0; k < P; ++k) {
      int v1 = nD;
      if (k < P - 1) {
        v1 = v0;
        const double target = total * double(k + 1) / double(P);
        while (v1 < nD - (P - 1 - k) && (v1 == v0 || acc + w[size_t(v1)] <= target))
          acc += w[size_t(v1++)];
      }
      double c = 0;
      for (int v = v0; v < v1; ++v) c += w[size_t(v)];
      work.push_back({c, {missing[size_t(m)], v0, v1}});
      v0 = v1;
    }
  }
  std::stable_sort(work.begin(), work.end(),
                   [](const Work& a, const Work& b) { return a.cost > b.cost; });
  std::vector<double> load(size_t(R), 0.0);
  std::vector<int> owner(size_t(info.chunks()), -1);
  for (const Work& x : work) {
    const int q = int(std::min_element(load.begin(), load.end()) - load.begin());
    load[size_t(q)] += x.cost;
    if (x.p.v0 == 0) owner[size_t(x.p.chunk)] = q;
    if (q != comm.rank()) continue;
    if (P == 1)
      mine[size_t(x.p.chunk)] = 1;
    else
      pieces.push_back(x.p);
  }
  if (P > 1)
    for (int c : missing) splits.push_back({c, owner[size_t(c)]});
  std::sort(pieces.begin(), pieces.end(), [](const ViewPiece& a, const ViewPiece& b) {
    return a.chunk != b.chunk ? a.chunk < b.chunk : a.v0 < b.v0;
  });
}

}  // namespace

SimEstimate SimulationJob::estimate(const std::string& outPath) const {
  SimEstimate e;
  e.threads = currentThreads();
  const EffectPlan& pl = plan();
  checkCancel();
  EffectPlan& plm = *m_plan;
  const bool pt = m_opt.method == "pt";
  const bool gi = !pt && pl.interreflection;
  const int nD = m_dirs.size();
  const int64_t texels = int64_t(m_opt.nu) * m_opt.nv;
  const uint64_t samples = uint64_t(texels) * uint64_t(m_mapSpp) * uint64_t(m_mapSpp);
  // Kernel calls: one per (texel, view) when adaptive (calibrated on whole texels), one per
  // (sample, view) when uniform (calibrated on 1-sample texels).
  const double units = m_adaptive ? double(texels) : double(samples);
  BtfInfo probe = storeInfo(1);
  const uint64_t texelBytes = probe.texelBytes();
  e.hitMapBytes = uint64_t(nD) * samples *
                  (HitMaps::kBytesPerSample + (m_adaptive ? HitMaps::kEdgeBytesPerSample : 0));
  const uint64_t vmfBytes = pl.vmf ? uint64_t(nD) * uint64_t(texels) * 8 : 0;
  if (gi)
    e.networkBytes = m_network->memoryBytes() +
                     NetworkLighting::memoryBytes(m_network->points().size(),
                                                  m_network->links().size(), nD, glossyGather());
  const uint64_t fixed =
      (64ull << 20) + e.hitMapBytes + vmfBytes + e.networkBytes + m_tracer->embreeTriangles() * 160;
  if (fixed + texelBytes * (outPath.empty() ? 1 : 2) > m_opt.memoryBudget) {
    e.refusal = "memory budget " + formatBytes(double(m_opt.memoryBudget)) +
                " is too small: hit maps need " + formatBytes(double(e.hitMapBytes)) +
                ", visibility map " + formatBytes(double(vmfBytes)) + ", point network " +
                formatBytes(double(e.networkBytes)) + ", one texel's " + std::to_string(nD) + "x" +
                std::to_string(nD) + " matrix " + formatBytes(double(texelBytes)) +
                " (lower --texels, --spp, the direction count or --network-voxels, or raise "
                "--memory-budget)";
  }
  const uint64_t buffers = outPath.empty() ? 1 : 2;
  uint64_t perChunk = std::max<uint64_t>(
      1, (m_opt.memoryBudget > fixed ? m_opt.memoryBudget - fixed : 0) / (texelBytes * buffers));
  perChunk = std::min<uint64_t>(perChunk, std::max<uint64_t>(1, m_opt.maxChunkBytes / texelBytes));
  if (m_opt.maxChunkTexels > 0)
    perChunk = std::min<uint64_t>(perChunk, uint64_t(m_opt.maxChunkTexels));
  // At least ~256 chunks of a multiple of 32 texels (32 at the least): the unit of resume and of
  // the work a cluster job spreads over its ranks (docs/cluster.md). The rule does not depend
  // on the rank count, so every rank count writes the same file.
  perChunk = std::min<uint64_t>(
      perChunk, std::max<uint64_t>(32, (uint64_t(texels) + 255) / 256 + 31) / 32 * 32);
  perChunk = std::min<uint64_t>(perChunk, uint64_t(texels));
  e.chunkTexels = int(perChunk);
  e.chunkBytes = perChunk * texelBytes;
  // Writing keeps two chunk buffers (one computed while the other is written).
  e.memoryBytes = fixed + e.chunkBytes * (outPath.empty() ? 1 : 2);
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

  // Time: calibrate on this scene — hit maps and the kernels with the same directions, materials
  // and plan on a coarser grid: the run's own up to 32 × 32 texels when adaptive (the
  // refinement depends on the texel size; fewer while the calibration's maps would pass
  // 256 MiB), else 8 × 8; cost per (sample, view) scales with nL.
  int calMax = 32;
  while (calMax > 8 && double(calMax) * calMax * m_mapSpp * m_mapSpp * nD *
                               (HitMaps::kBytesPerSample + HitMaps::kEdgeBytesPerSample) >
                           double(256 << 20))
    calMax /= 2;
  const int calU = m_adaptive ? std::min(m_opt.nu, calMax) : 8;
  const int calV = m_adaptive ? std::min(m_opt.nv, calMax) : 8;
  SampleGrid g{calU, calV, m_adaptive ? m_mapSpp : 1, m_scene.Lx, m_scene.Ly, m_opt.seed};
  HitMaps maps;
  auto t0 = Clock::now();
  withThreads(1, [&] {
    maps.build(*m_tracer, m_dirs, g, nullptr, m_cancel);
    if (m_adaptive) maps.buildEdgeTables(m_geom, m_cancel);
  });
  checkCancel();
  const double perRay = since(t0) / double(maps.raysTraced());
  const double threads = std::max(1, e.threads);
  const ShadowMode mode = pl.selfShadowing ? m_opt.shadows : ShadowMode::None;
  std::vector<float> buf(size_t(nD) * 3);
  // Kernel calls spread over the grid's texels and the views (hashed): the adaptive cost of a
  // (texel, view) varies tenfold between a flat texel and one on an edge.
  const int calls =
      m_adaptive ? int(std::min<int64_t>(1024, int64_t(nD) * calU * calV)) : std::min(64, nD * 4);
  auto timeKernel = [&](ShadowMode m, const NetworkGather* gather, bool pathTrace,
                        double grazingRays) {
    checkCancel();
    DirectIllumination direct(*m_tracer, m_materials, m_dirs, maps,
                              {m, m_opt.shadowBias, grazingRays});
    TexelKernel k{*m_tracer, m_materials, m_dirs, maps, direct, gather,
                  pathTrace, nullptr,     {},     1,    {}};
    std::unique_ptr<AdaptiveTexelSampler> ad;
    AdaptiveStats st;
    if (m_adaptive) {
      ad = std::make_unique<AdaptiveTexelSampler>(*m_tracer, m_materials, m_dirs, maps, direct,
                                                  gather, m_opt.adaptiveSettings, &st);
      k.adaptive = ad.get();
    }
    k.ptPaths = 1;
    k.pt.maxBounces = pl.interreflection ? pl.bounces : 1;
    for (const auto& d : m_dirs.dirs()) k.lights.push_back(DVec3(Vec3(d.w)));
    const auto t = Clock::now();
    // Adaptive: runs of consecutive texels along a row seen from one view, as run() goes (view
    // by view over the texels: neighbouring texels share the lights' map lines), each run at a
    // hashed texel and view.
    const int run = std::min(16, calU);
    for (int c = 0; c < calls; ++c) {
      if (m_adaptive) {
        const uint64_t h = hashKeys(m_opt.seed, uint64_t(c / run), 0x7e5717a7e, 0);
        const uint64_t tx = (h & 0xffffffffu) % uint64_t(calU * calV);
        k.eval(int((tx % uint64_t(calU) + uint64_t(c % run)) % uint64_t(calU)),
               int(tx / uint64_t(calU)), int((h >> 32) % uint64_t(nD)), buf.data());
      } else {
        k.eval(c % 8, (c / 8) % 8, (c * 7) % nD, buf.data());
      }
    }
    double perCall = since(t) / calls * (pathTrace ? m_opt.ptPaths : 1);
    if (m_adaptive && !pathTrace) {
      // Beyond its 32 × 32 the calibration's texels are larger than the run's: more of them
      // straddle an edge. The refinement beyond level 0 falls with the texel size; measured on
      // brick (8×8 → 32², 64²) it goes as its square root. In (sample, light) evaluations per
      // value (a closed-form value costs one per face): e → b + (e − b)·√(cal / N), b = level
      // 0's share (4, or e).
      double values = 0;
      for (const auto& v : st.values) values += double(v.load());
      const double e = values > 0 ? double(st.evaluations.load()) / values : 4.0;
      const double b = std::min(4.0, e);
      const double r = std::sqrt(
          std::min(1.0, double(std::max(calU, calV)) / double(std::max(m_opt.nu, m_opt.nv))));
      if (e > 0) perCall *= (b + (e - b) * r) / e;
    }
    return perCall;
  };
  const double perSampleView = timeKernel(mode, nullptr, pt, m_opt.grazingRays);
  e.hitMapSeconds = double(nD) * double(samples) * perRay / threads;
  if (EffectDecision* gr = plm.find("grazing_rays"); gr && gr->value != "none") {
    // What exact rays for the grazing lights cost over the map alone.
    const double mapOnly = timeKernel(mode, nullptr, false, 90);
    const double cost = units * double(nD) * std::max(0.0, perSampleView - mapOnly) / threads;
    gr->secondsSaved = -cost;  // a cost: printed as such, kept out of the store's header
  }
  e.evalSeconds = units * double(nD) * perSampleView / threads;
  // What each planner decision saves (or would cost).
  if (!pt && !pl.selfShadowing) {
    const double with = timeKernel(m_opt.shadows, nullptr, false, m_opt.grazingRays);
    plm.find("self_shadowing")->secondsSaved =
        std::max(0.0, units * double(nD) * (with - perSampleView) / threads);
  }
  if (!pt && m_network && !m_network->points().empty()) {
    // Network solve: two lights on one thread; gather: the same calls with the final gather.
    DirectIllumination direct(*m_tracer, m_materials, m_dirs, maps,
                              {mode, m_opt.shadowBias, m_opt.grazingRays});
    NetworkLighting light;
    const int P = pl.interreflection ? pl.bounces : std::max(2, m_opt.plan.maxAutoBounces);
    const int nCal = std::min(2, nD);
    withThreads(1, [&] {
      light.solve(
          *m_network, m_geom, m_materials, m_dirs,
          [&](int l, const Vec3& p, const Vec3& ng, uint32_t prim) {
            return direct.lightVisibility(l, p, ng, prim);
          },
          P, glossyGather(), nullptr, m_cancel, nCal);
    });
    checkCancel();
    const double perLight = (light.solveSeconds() - light.setupSeconds()) / nCal;
    NetworkGather gather(*m_network, light, m_geom, m_materials, m_tracer.get());
    const double withGather = timeKernel(mode, &gather, false, m_opt.grazingRays);
    const double lightSeconds = light.setupSeconds() + perLight * nD / threads;
    const double gatherSeconds =
        units * double(nD) * std::max(0.0, withGather - perSampleView) / threads;
    if (gi && !pl.glossyIndirect && anyGlossy(m_materials)) {
      // What gathering through the glossy lobes would have cost (mean-direction variant).
      NetworkLighting lg;
      withThreads(1, [&] {
        lg.solve(
            *m_network, m_geom, m_materials, m_dirs,
            [&](int l, const Vec3& p, const Vec3& ng, uint32_t prim) {
              return direct.lightVisibility(l, p, ng, prim);
            },
            P, GlossyGather::MeanDirection, nullptr, m_cancel, nCal);
      });
      checkCancel();
      NetworkGather gg(*m_network, lg, m_geom, m_materials, m_tracer.get());
      const double withGlossy = timeKernel(mode, &gg, false, m_opt.grazingRays);
      plm.find("glossy_indirect")->secondsSaved =
          units * double(nD) * std::max(0.0, withGlossy - withGather) / threads;
    }
    if (gi) {
      e.networkSeconds = 0;  // already built by the planner
      e.lightSeconds = lightSeconds;
      e.gatherSeconds = gatherSeconds;
      e.evalSeconds += gatherSeconds;
      if (!plm.find("bounces")->forced && pl.bounces < m_opt.plan.maxAutoBounces)
        plm.find("bounces")->secondsSaved =
            lightSeconds / std::max(1, pl.bounces - 1) * (m_opt.plan.maxAutoBounces - pl.bounces);
    } else {
      plm.find("interreflection")->secondsSaved =
          m_network->buildSeconds() + lightSeconds + gatherSeconds;
    }
  }
  e.seconds = e.hitMapSeconds + e.evalSeconds + e.lightSeconds;
  return e;
}

SimReport SimulationJob::run(const std::string& outPath, const SimEstimate& est,
                             const CancelToken* cancel) {
  if (!est.refusal.empty()) throw Error(est.refusal);
  SimReport r;
  r.output = outPath;
  const auto start = Clock::now();
  const EffectPlan& pl = plan();
  const bool pt = m_opt.method == "pt";
  const bool gi = !pt && pl.interreflection;
  const BtfInfo info = storeInfo(est.chunkTexels);
  Comm& comm = m_comm ? *m_comm : localComm();
  const bool dist = comm.distributed();
  const uint64_t comm0 = comm.bytesSent() + comm.bytesReceived();
  std::unique_ptr<BtfWriter> writer;
  if (!outPath.empty() && !dist) writer = std::make_unique<BtfWriter>(outPath, info, m_opt.resume);
  if (!outPath.empty() && dist) {
    // Rank 0 creates or resumes (and verifies) the partial; then the others open it, and learn
    // from rank 0 which chunks are done.
    collectively(comm, [&] {
      if (comm.root()) writer = std::make_unique<BtfWriter>(outPath, info, m_opt.resume);
    });
    collectively(comm, [&] {
      if (!comm.root()) writer = std::make_unique<BtfWriter>(outPath, info, BtfWriter::Attach{});
    });
    std::string done;
    if (comm.root()) done.assign(writer->doneFlags().begin(), writer->doneFlags().end());
    comm.broadcast(done, 0);
    if (!comm.root()) writer->setDone(std::vector<uint8_t>(done.begin(), done.end()));
  }
  std::vector<uint8_t> mine(size_t(info.chunks()), 1);  // this rank's chunks (after the maps)
  r.ranks = comm.size();
  r.chunks = info.chunks();
  r.chunksResumed = writer ? writer->chunksDone() : 0;
  if (writer) r.resumeNote = writer->resumeNote();
  if (m_network && gi) {
    r.networkSeconds = m_network->buildSeconds();
    r.networkPoints = m_network->points().size();
    r.networkLinks = m_network->links().size();
  }

  SampleGrid grid{m_opt.nu, m_opt.nv, m_mapSpp, m_scene.Lx, m_scene.Ly, m_opt.seed};
  HitMaps maps;
  {
    ProgressReporter pr("hit maps", m_dirs.size(), m_opt.progress);
    maps.build(*m_tracer, m_dirs, grid, &pr, cancel);
    if (m_adaptive) maps.buildEdgeTables(m_geom, cancel);
    pr.finish();
  }
  r.hitMapSeconds = since(start);
  r.hitMapRays = maps.raysTraced();
  // A cluster job's work: the missing chunks, by estimated cost, largest first to the least
  // loaded rank (every rank computes the same assignment from the same maps). When fewer chunks
  // are missing than twice the ranks, each is cut into pieces of contiguous views (cut at equal
  // cost) so that no rank idles; a split chunk's pieces are gathered on the rank of its first
  // piece, which writes (or encodes) it. Cost: one per (texel, view), four more where the view's
  // map has an edge in the texel's footprint — where adaptive sampling refines.
  std::vector<ViewPiece> pieces;   // this rank's pieces of split chunks
  std::vector<SplitChunk> splits;  // every split chunk, in chunk order
  if (dist)
    assignWork(info, maps, m_opt.nu, m_dirs.size(), writer.get(), comm, mine, pieces, splits);
  r.precomputeSeconds = r.hitMapSeconds + (gi ? r.networkSeconds : 0);
  throwIfCancelled(cancel, "hit maps");
  const int nD = m_dirs.size();
  if (writer && comm.root()) {
    std::vector<float> vmf;
    if (info.hasVmf) {
      vmf.reserve(size_t(nD) * size_t(info.texels()) * 2);
      for (int d = 0; d < nD; ++d) {
        auto v = maps.vmf(d);
        vmf.insert(vmf.end(), v.begin(), v.end());
      }
    }
    writer->writeVmf(vmf);
  }

  const ShadowMode mode = pl.selfShadowing ? m_opt.shadows : ShadowMode::None;
  DirectIllumination direct(*m_tracer, m_materials, m_dirs, maps,
                            {mode, m_opt.shadowBias, m_opt.grazingRays});
  NetworkLighting lighting;
  lighting.setClosedFormTail(pl.closedFormTail);
  std::unique_ptr<NetworkGather> gather;
  const auto renderStart = Clock::now();
  if (gi) {
    ProgressReporter pr("network light", nD, m_opt.progress);
    lighting.solve(
        *m_network, m_geom, m_materials, m_dirs,
        [&](int l, const Vec3& p, const Vec3& ng, uint32_t prim) {
          return direct.lightVisibility(l, p, ng, prim);
        },
        pl.bounces, glossyGather(), &pr, cancel);
    pr.finish();
    r.lightSeconds = lighting.solveSeconds();
    gather =
        std::make_unique<NetworkGather>(*m_network, lighting, m_geom, m_materials, m_tracer.get());
    throwIfCancelled(cancel, "network light");
  }
  TexelKernel kernel{*m_tracer, m_materials, m_dirs, maps, direct, gather.get(),
                     pt,        nullptr,     {},     1,    {}};
  AdaptiveStats adStats;
  std::unique_ptr<AdaptiveTexelSampler> adaptive;
  if (m_adaptive) {
    adaptive = std::make_unique<AdaptiveTexelSampler>(*m_tracer, m_materials, m_dirs, maps, direct,
                                                      gather.get(), m_opt.adaptiveSettings,
                                                      m_onlyTrainingTexels ? nullptr : &adStats);
    kernel.adaptive = adaptive.get();
  }
  kernel.ptPaths = m_opt.ptPaths;
  kernel.pt.maxBounces = pl.interreflection ? pl.bounces : 1;
  kernel.pt.seed = m_opt.seed;
  for (const auto& d : m_dirs.dirs()) kernel.lights.push_back(DVec3(Vec3(d.w)));

  // Test hooks: a kill after N chunks (of rank BTF_TEST_ABORT_RANK only, when set).
  const char* abortEnv = std::getenv("BTF_TEST_ABORT_AFTER_CHUNKS");
  const char* abortRank = std::getenv("BTF_TEST_ABORT_RANK");
  const int abortAfter =
      abortEnv && (!abortRank || std::atoi(abortRank) == comm.rank()) ? std::atoi(abortEnv) : -1;
  int written = 0;
  // Two buffers: chunk c is written by a background task while chunk c + 1 is computed.
  std::vector<float> buffers[2];
  int cur = 0;
  std::future<double> pending;  // the background write; returns its duration
  auto waitWrite = [&] {
    if (!pending.valid()) return;
    r.writeSeconds += pending.get();
    if (++written == abortAfter) {
      std::fprintf(stderr, "\nBTF_TEST_ABORT_AFTER_CHUNKS: exiting abruptly after %d chunk(s)\n",
                   written);
      if (std::getenv("BTF_TEST_ABORT_KILL")) std::raise(SIGKILL);  // as `kill -9` would
      std::_Exit(75);
    }
  };
  std::atomic<uint64_t> evals{0};
  if (!m_trainTexels.empty() && m_trainSink) {
    const int64_t n = int64_t(m_trainTexels.size());
    const size_t stride = size_t(nD) * size_t(nD) * 3;
    std::vector<float> values(size_t(n) * stride, 0.f);
    // A cluster job: rank r computes the training texels r, r + N, …, then every rank gets all.
    const int64_t R = comm.size(), me = comm.rank();
    const int64_t myN = n / R + (me < n % R ? 1 : 0);
    std::vector<float> local(size_t(myN) * stride, 0.f);
    ProgressReporter tp("training texels", myN, m_opt.progress);
    parallelForChunks(
        myN * nD, pt ? 1 : 8,
        [&](int64_t b, int64_t e) {
          for (int64_t k = b; k < e; ++k) {
            const int64_t t = m_trainTexels[size_t((k / nD) * R + me)];
            const int view = int(k % nD);
            kernel.eval(int(t % m_opt.nu), int(t / m_opt.nu), view,
                        &local[size_t(k / nD) * stride + size_t(view) * nD * 3]);
            if (view == nD - 1) tp.add(1);
          }
        },
        cancel);
    throwIfCancelled(cancel, "training texels");
    tp.finish();
    if (!dist) {
      values.swap(local);
    } else {
      const std::vector<std::string> all = comm.allgather(
          std::string(reinterpret_cast<const char*>(local.data()), local.size() * sizeof(float)));
      for (int64_t q = 0; q < R; ++q) {
        const float* src = reinterpret_cast<const float*>(all[size_t(q)].data());
        for (int64_t i = q, j = 0; i < n; i += R, ++j)
          std::copy(src + size_t(j) * stride, src + size_t(j + 1) * stride,
                    values.begin() + ptrdiff_t(size_t(i) * stride));
      }
    }
    m_trainSink(values.data());
    if (m_onlyTrainingTexels) {
      r.wallSeconds = since(start);
      return r;
    }
  }
  int64_t myTexels = 0;
  for (int c = 0; c < info.chunks(); ++c)
    if (mine[size_t(c)] && !(writer && writer->chunkDone(c)))
      myTexels += info.chunkEnd(c) - info.chunkBegin(c);
  for (const ViewPiece& p : pieces) myTexels += info.chunkEnd(p.chunk) - info.chunkBegin(p.chunk);
  ProgressReporter pr("aBRDF", dist ? myTexels : info.texels(), m_opt.progress);
  const auto evalStart = Clock::now();
  const size_t stride = size_t(nD) * size_t(nD) * 3;  // floats per texel
  // Views [v0, v1) of texels [t0, t1) into `out` (texel t's view v at (t − t0)·texelStride +
  // (v − v0)·nD·3). Work items: (block of B texels, view); B > 1 only for the plain direct kernel.
  auto computeViews = [&](int64_t t0, int64_t t1, int v0, int v1, float* out, size_t texelStride) {
    const int B = kernel.blockTexels();
    const int64_t blocks = (t1 - t0 + B - 1) / B, nv = v1 - v0;
    // The texel-by-texel kernels go view by view over the texels: neighbouring texels seen from
    // one view read neighbouring parts of each light's map (shadow-map taps, edge tables, block
    // maxima), so consecutive items share cache lines. Progress counts a texel per nv items.
    const bool viewMajor = B == 1 && !pt;
    std::atomic<int64_t> itemsDone{0};
    parallelForChunks(
        blocks * nv, viewMajor ? 32 : 1,
        [&](int64_t b, int64_t e) {
          uint64_t local = 0;
          for (int64_t k = b; k < e; ++k) {
            const int64_t tb = t0 + (viewMajor ? k % blocks : k / nv) * B;
            const int n = int(std::min<int64_t>(B, t1 - tb));
            const int view = v0 + int(viewMajor ? k / blocks : k % nv);
            local += uint64_t(kernel.evalBlock(
                tb, n, m_opt.nu, view,
                out + size_t(tb - t0) * texelStride + size_t(view - v0) * nD * 3, texelStride));
            if (!viewMajor && view == v1 - 1) pr.add(n);
          }
          if (viewMajor) {
            const int64_t before = itemsDone.fetch_add(e - b);
            pr.add((before + e - b) / nv - before / nv);
          }
          evals += local;
        },
        cancel);
    r.abrdfValues += uint64_t(t1 - t0) * uint64_t(nv) * uint64_t(nD);
    r.texelsComputed += double(t1 - t0) * double(nv) / double(nD);
  };
  // This rank's pieces of split chunks, each texel's views [v0, v1) contiguous.
  std::vector<std::vector<float>> pieceValues(pieces.size());
  // On one rank, a failure ends the run here; in a cluster job every rank first reaches the
  // agreement below (so none waits forever), then all fail with the failing rank's message.
  collectively(comm, [&] {
    for (int c = 0; c < info.chunks(); ++c) {
      const int64_t t0 = info.chunkBegin(c), t1 = info.chunkEnd(c);
      if (!mine[size_t(c)]) continue;
      if (writer && writer->chunkDone(c)) {
        pr.add(t1 - t0);
        continue;
      }
      ++r.chunksComputed;
      std::vector<float>& chunk = buffers[cur];
      chunk.assign(size_t(t1 - t0) * stride, 0.f);
      computeViews(t0, t1, 0, nD, chunk.data(), stride);
      if (cancel && cancel->cancelled()) {
        waitWrite();  // the chunk in flight lands in the .partial; then the one outcome
        throw Cancelled("aBRDF");
      }
      if (m_sink) m_sink(c, t0, t1, chunk.data());
      if (writer) {
        waitWrite();  // at most one write in flight: the other buffer is free again
        pending = std::async(std::launch::async, [&writer, c, data = chunk.data()] {
          const auto w0 = Clock::now();
          writer->writeChunk(c, data);
          return since(w0);
        });
        cur ^= 1;
      }
    }
    waitWrite();
    for (size_t i = 0; i < pieces.size(); ++i) {
      const ViewPiece& p = pieces[i];
      const int64_t t0 = info.chunkBegin(p.chunk), t1 = info.chunkEnd(p.chunk);
      const size_t ps = size_t(p.v1 - p.v0) * size_t(nD) * 3;
      pieceValues[i].assign(size_t(t1 - t0) * ps, 0.f);
      computeViews(t0, t1, p.v0, p.v1, pieceValues[i].data(), ps);
      throwIfCancelled(cancel, "aBRDF");
    }
    r.rankEvalSeconds = since(evalStart);  // this rank's own work, before the agreement
  });
  if (!splits.empty()) {
    // Split chunks: every rank sends its pieces of chunk c to c's owner (one gather per chunk,
    // in chunk order, every rank taking part), which assembles, encodes and writes it.
    std::vector<std::pair<int, std::vector<float>>> assembled;
    for (const SplitChunk& sc : splits) {
      std::string mineBytes;
      for (size_t i = 0; i < pieces.size(); ++i) {
        if (pieces[i].chunk != sc.chunk) continue;
        const int32_t range[2] = {pieces[i].v0, pieces[i].v1};
        mineBytes.append(reinterpret_cast<const char*>(range), sizeof range);
        mineBytes.append(reinterpret_cast<const char*>(pieceValues[i].data()),
                         pieceValues[i].size() * sizeof(float));
        std::vector<float>().swap(pieceValues[i]);
      }
      const std::vector<std::string> got = comm.gather(mineBytes, sc.owner);
      if (comm.rank() != sc.owner) continue;
      const int64_t t0 = info.chunkBegin(sc.chunk), t1 = info.chunkEnd(sc.chunk);
      std::vector<float> chunk(size_t(t1 - t0) * stride, 0.f);
      int covered = 0;
      for (const std::string& g : got) {
        size_t o = 0;
        while (o < g.size()) {
          int32_t range[2];
          BTF_CHECK(g.size() - o >= sizeof range);
          std::memcpy(range, g.data() + o, sizeof range);
          o += sizeof range;
          BTF_CHECK(range[0] >= 0 && range[0] < range[1] && range[1] <= nD);
          const size_t ps = size_t(range[1] - range[0]) * size_t(nD) * 3;
          BTF_CHECK(g.size() - o >= size_t(t1 - t0) * ps * sizeof(float));
          for (int64_t t = t0; t < t1; ++t)
            std::memcpy(&chunk[size_t(t - t0) * stride + size_t(range[0]) * nD * 3],
                        g.data() + o + size_t(t - t0) * ps * sizeof(float), ps * sizeof(float));
          o += size_t(t1 - t0) * ps * sizeof(float);
          covered += range[1] - range[0];
        }
      }
      BTF_CHECK(covered == nD);  // every view of the chunk, once
      assembled.push_back({sc.chunk, std::move(chunk)});
    }
    collectively(comm, [&] {
      for (const auto& [c, chunk] : assembled) {
        ++r.chunksComputed;
        if (m_sink) m_sink(c, info.chunkBegin(c), info.chunkEnd(c), chunk.data());
        if (writer) writer->writeChunk(c, chunk.data());
      }
    });
  }
  pr.finish();
  // Writes overlap the compute: the time spent waiting for the last one is not compute.
  r.evalSeconds = since(evalStart);
  r.renderSeconds = since(renderStart);
  r.brdfEvaluations = evals.load();
  if (dist) {
    // The job's totals, on every rank.
    std::vector<double> sums = {double(r.abrdfValues), double(r.brdfEvaluations)};
    if (m_adaptive) {
      const std::vector<double> a = adStats.toVector();
      sums.insert(sums.end(), a.begin(), a.end());
    }
    sums = sumInRankOrder(comm, sums);
    r.abrdfValues = uint64_t(sums[0]);
    r.brdfEvaluations = uint64_t(sums[1]);
    if (m_adaptive) adStats.assign(std::vector<double>(sums.begin() + 2, sums.end()));
  }
  if (m_adaptive) {
    r.adaptive = true;
    r.samplingJson = adStats.json();
    r.samplingText = adStats.histogramText();
    r.meanSamples = adStats.meanSamples();
    r.estimatedError = adStats.estimatedRelativeError();
  }
  if (writer) {
    // In a cluster job every rank's chunks are in the file once all have passed the agreement
    // above; rank 0 checks the table and renames.
    collectively(comm, [&] {
      if (!dist)
        writer->finish();
      else if (comm.root())
        writer->finishShared();
    });
    r.outputBytes = btfFileBytes(info);
  }
  r.commBytes = comm.bytesSent() + comm.bytesReceived() - comm0;
  r.wallSeconds = since(start);
  r.peakRssBytes = peakRssBytes();
  return r;
}

std::vector<float> SimulationJob::evaluateTexels(const std::vector<int64_t>& texels,
                                                 const CancelToken* cancel) {
  for (int64_t t : texels)
    if (t < 0 || t >= int64_t(m_opt.nu) * m_opt.nv) throw Error("texel index out of range");
  std::vector<float> out;
  const size_t n = texels.size() * size_t(m_dirs.size()) * size_t(m_dirs.size()) * 3;
  auto savedTexels = std::move(m_trainTexels);
  auto savedSink = std::move(m_trainSink);
  m_trainTexels = texels;
  m_trainSink = [&](const float* v) { out.assign(v, v + n); };
  m_onlyTrainingTexels = true;
  const bool progress = m_opt.progress;
  m_opt.progress = false;
  SimEstimate est;
  est.chunkTexels = m_opt.nu * m_opt.nv;
  try {
    run("", est, cancel);
  } catch (...) {
    m_onlyTrainingTexels = false;
    m_opt.progress = progress;
    m_trainTexels = std::move(savedTexels);
    m_trainSink = std::move(savedSink);
    throw;
  }
  m_onlyTrainingTexels = false;
  m_opt.progress = progress;
  m_trainTexels = std::move(savedTexels);
  m_trainSink = std::move(savedSink);
  throwIfCancelled(cancel, "texel evaluation");
  return out;
}

std::vector<float> SimulationJob::renderPair(const Direction& view, const Direction& light, int nu,
                                             int nv, bool indirect,
                                             const CancelToken* cancel) const {
  if (nu < 1 || nv < 1 || nu > 8192 || nv > 8192) throw Error("preview size must be 1..8192");
  // The pair as a two-direction set: the view's hit map and the light's shadow map are the same
  // rays as in the full set, so each value is the one run() stores for that pair.
  const DirectionSet pair = DirectionSet::subset("pair", {view, light});
  const bool pt = m_opt.method == "pt";
  const EffectPlan* pl = indirect ? &plan() : nullptr;
  const bool selfShadowing = pl ? pl->selfShadowing : true;
  const bool gi = indirect && !pt && pl->interreflection;
  SampleGrid grid{nu, nv, m_mapSpp, m_scene.Lx, m_scene.Ly, m_opt.seed};
  HitMaps maps;
  maps.build(*m_tracer, pair, grid, nullptr, cancel);
  if (m_adaptive) maps.buildEdgeTables(m_geom, cancel);
  std::vector<float> img(size_t(nu) * size_t(nv) * 3, 0.f);
  throwIfCancelled(cancel, "preview");
  const ShadowMode mode = selfShadowing ? m_opt.shadows : ShadowMode::None;
  DirectIllumination direct(*m_tracer, m_materials, pair, maps,
                            {mode, m_opt.shadowBias, m_opt.grazingRays});
  NetworkLighting lighting;
  lighting.setClosedFormTail(pl && pl->closedFormTail);
  std::unique_ptr<NetworkGather> gather;
  if (gi) {
    const GlossyGather glossy = glossyGather();
    lighting.solve(
        *m_network, m_geom, m_materials, pair,
        [&](int l, const Vec3& p, const Vec3& ng, uint32_t prim) {
          return direct.lightVisibility(l, p, ng, prim);
        },
        pl->bounces, glossy, nullptr, cancel);
    throwIfCancelled(cancel, "preview");
    gather =
        std::make_unique<NetworkGather>(*m_network, lighting, m_geom, m_materials, m_tracer.get());
  }
  TexelKernel kernel{*m_tracer,      m_materials, pair, maps, direct, gather.get(),
                     pt && indirect, nullptr,     {},   1,    {}};
  std::unique_ptr<AdaptiveTexelSampler> adaptive;
  if (m_adaptive) {
    adaptive = std::make_unique<AdaptiveTexelSampler>(
        *m_tracer, m_materials, pair, maps, direct, gather.get(), m_opt.adaptiveSettings, nullptr);
    kernel.adaptive = adaptive.get();
  }
  kernel.ptPaths = m_opt.ptPaths;
  kernel.pt.maxBounces = pl && pl->interreflection ? pl->bounces : 1;
  kernel.pt.seed = m_opt.seed;
  for (const auto& d : pair.dirs()) kernel.lights.push_back(DVec3(Vec3(d.w)));
  parallelForChunks(
      int64_t(nu) * nv, 64,
      [&](int64_t b, int64_t e) {
        float row[6];
        for (int64_t t = b; t < e; ++t) {
          kernel.eval(int(t % nu), int(t / nu), 0, row);
          for (int c = 0; c < 3; ++c) {
            const float v = row[3 + c];
            img[size_t(t) * 3 + c] = std::isfinite(v) ? v : 0.f;
          }
        }
      },
      cancel);
  throwIfCancelled(cancel, "preview");
  return img;
}

}  // namespace btf
