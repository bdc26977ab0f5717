// The simulation job: options from the scene, the tile's tracer and materials, the effect plan,
// the point network, the store's layout, and the direct entry points that evaluate chosen texels
// or one (view, light) pair (the preview). The run and its estimate are in sim_run.cpp and
// sim_estimate.cpp.
#include <btf/sim/network_cache.h>

#include "texel_kernel.h"

namespace btf {

using namespace simdetail;

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
  const std::string& vis = m_opt.visibility;
  if (vis != "auto" && vis != "exact" && vis != "sampled")
    throw Error("unknown --visibility '" + vis + "' (expected auto, exact or sampled)");
  if (vis == "exact" && m_opt.method == "pt")
    throw Error("--visibility exact is the network method's: --method pt path traces every value");
  if (vis != "sampled" && m_opt.method != "pt") {
    auto ex = std::make_unique<ExactDirect>(m_geom, m_materials, m_dirs, m_opt.nu, m_opt.nv);
    if (vis == "exact" || (m_adaptive && ex->allFlat())) {
      // Asked for: the smooth faces too, shaded by their vertices' planes.
      ex->setShadeSmooth(vis == "exact");
      // Flat faces are exact; the hit maps (4 × 4 when adaptive was asked for) serve the smooth
      // faces' uniform samples, the visibility map and the network's final gather, whose
      // samples are the texel's (2 × 2 gives brick 6² texels 6.4 % from uniform 16 × 16).
      m_adaptive = false;
      m_exact = std::move(ex);
    }
  }
}

std::string SimulationJob::visibilityName() const {
  if (!m_exact) return "sampled";
  return m_exact->allFlat() ? "exact" : "exact+sampled";
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
      m_network = sharedNetwork(*m_tracer, m_geom, networkSettings(), m_cancel, &m_networkReused);
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
    if (m_exact) {
      char reason[320];
      const ExactStats& s = m_exact->stats();
      std::snprintf(reason, sizeof reason,
                    "%lld of %lld faces flat: their direct light is exact by area (seen and lit "
                    "parts as polygons, no samples)%s",
                    (long long)s.flatFaces, (long long)s.faces,
                    m_exact->allFlat() ? "" : "; smooth faces sampled uniformly on the hit maps");
      m_plan->decisions.push_back(
          {"visibility", visibilityName(), reason, m_opt.visibility == "exact", 0});
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
    plan["network"]["reciprocal_gather"] = m_opt.reciprocalGather;
    plan["network"]["glossy_gather"] = glossyGatherName(glossyGather());
    plan["network"]["points"] = m_network->points().size();
    plan["network"]["link_count"] = m_network->links().size();
  }
  i.plan = plan.dump();
  return i;
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
  // Exact visibility: the pair's flat faces by area (the network's light still sees the
  // sampled visibility of the full run).
  std::unique_ptr<ExactDirect> exact;
  if (m_exact && !(pt && indirect)) {
    exact = std::make_unique<ExactDirect>(m_geom, m_materials, pair, nu, nv);
    exact->setShadeSmooth(m_exact->shadeSmooth());
    exact->prepare(nullptr, cancel);
    direct.skipTriangles(exact->shadedMask());
  }
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
    if (m_opt.reciprocalGather)
      gather->setScale(
          reciprocalScale(gatherTileSums(*gather, maps, m_geom, pair, localComm(), nullptr, cancel),
                          pair.size())
              .scale);
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
  if (exact) {
    std::vector<float> e(img.size());
    exact->evalPair(0, 1, e.data());
    for (size_t k = 0; k < img.size(); ++k) img[k] += e[k];
  }
  return img;
}

}  // namespace btf
