// The time and memory estimate of a simulation, before it runs: the hit maps' cost per ray and
// the kernel's cost per (texel, view) call, calibrated on the run's own grid.
#include "texel_kernel.h"

namespace btf {

using namespace simdetail;

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
    if (m_exact) direct.skipTriangles(m_exact->shadedMask());
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
  if (m_exact) {
    // Exact visibility: its hidden-surface removal and per-pair accumulation timed on up to six
    // directions of the set (spread over it, the last included), at the run's texels.
    std::vector<Direction> sub;
    const int nCal = std::min(nD, 6);
    for (int q = 0; q < nCal; ++q) sub.push_back(m_dirs[nCal == 1 ? 0 : q * (nD - 1) / (nCal - 1)]);
    const DirectionSet cal = DirectionSet::subset("calibration", sub);
    ExactDirect ex(m_geom, m_materials, cal, m_opt.nu, m_opt.nv);
    ex.setShadeSmooth(m_exact->shadeSmooth());
    const int64_t calTexels = std::min<int64_t>(texels, int64_t(e.chunkTexels));
    std::vector<float> out(size_t(calTexels) * size_t(nCal) * 3);
    double hsr = 0, pairs = 0;
    withThreads(1, [&] {
      auto t = Clock::now();
      ex.prepare(nullptr, m_cancel);
      hsr = since(t) / nCal;
      t = Clock::now();
      for (int v = 0; v < nCal; ++v) ex.evalView(v, 0, calTexels, out.data(), size_t(nCal) * 3);
      pairs = since(t) / (double(nCal) * nCal) * double(texels) / double(calTexels);
    });
    checkCancel();
    e.exactSeconds = (hsr * nD + pairs * double(nD) * nD) / threads;
    e.evalSeconds += e.exactSeconds;
  }
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
      if (m_opt.reciprocalGather) {
        // The tile sums: every hit-map sample of every view once (timed on up to 2048 of the
        // calibration's hits), then per view a weighted sum over the points it touched (timed
        // once, scaled to every point). The hits' occlusion rays are not counted: the texels'
        // gather, timed above with them, reads them back from the sums' cache instead.
        NetworkGather::Weights acc;
        acc.reset(m_network->points().size(), m_network->links().size(), light.lights());
        const SampleGrid& cg = maps.grid();
        const int64_t n = std::min<int64_t>(2048, cg.samples() * nD);
        int64_t used = 0;
        std::vector<double> sums(size_t(light.lights()) * 3);
        double perHit = 0, perPoint = 0, perAlpha = 0;
        withThreads(1, [&] {
          auto t = Clock::now();
          for (int64_t k = 0; k < n; ++k) {
            const int view = int(k % nD);
            const int64_t si = (k / nD * 7919) % cg.samples();
            const uint32_t prim = maps.prim(view, si);
            if (prim == kNoHit) continue;
            const DVec3 wv = m_dirs[view].w;
            const Vec3 p = Vec3(cg.position(int(si % cg.su()), int(si / cg.su())) +
                                double(maps.depth(view, si)) * wv);
            Vec3 ng, ns;
            if (!hitNormals(m_geom, prim, maps.bu(view, si), maps.bv(view, si), Vec3(wv), &ng,
                            &ns))
              continue;
            gather.addWeights(p, ng, ns, prim, Vec3(wv), 1.0f, acc);
            ++used;
          }
          perHit = used ? since(t) / double(used) : 0;
          if (gather.occlusionRays() > 0 && used > 0) {
            t = Clock::now();
            for (int64_t k = 0; k < std::min<int64_t>(n, 256); ++k)
              gather.occlusion(m_network->points()[size_t(k) % m_network->points().size()].p,
                               m_network->points()[size_t(k) % m_network->points().size()].ng);
            perAlpha = since(t) / double(std::min<int64_t>(n, 256));
          }
          t = Clock::now();
          gather.sumWeights(acc, sums.data());
          const size_t touched = acc.touchedPoints.size() + acc.touchedLinks.size();
          perPoint = touched ? since(t) / double(touched) : 0;
        });
        checkCancel();
        const double hits = double(nD) * double(texels) * m_mapSpp * m_mapSpp *
                            (used > 0 ? double(used) / double(n) : 0.0);
        e.reciprocalSeconds =
            (std::max(0.0, perHit - perAlpha) * hits +
             perPoint * double(nD) *
                 double(m_network->points().size() +
                        (glossyGather() == GlossyGather::Links ? m_network->links().size() : 0))) /
            threads;
        e.evalSeconds += e.reciprocalSeconds;
      }
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

}  // namespace btf
