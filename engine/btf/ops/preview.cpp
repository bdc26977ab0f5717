// The live preview's stages (engine/btf/ops/preview.h).
#include <btf/core/error.h>
#include <btf/core/run_context.h>
#include <btf/ops/preview.h>
#include <btf/sim/brdf_probe.h>
#include <btf/sim/simulator.h>

#include <chrono>
#include <cmath>
#include <cstdio>

namespace btf::ops {

using Clock = std::chrono::steady_clock;

std::array<double, 2> curveDirection(double signedTheta, double phi) {
  if (signedTheta >= 0) return {signedTheta, phi};
  return {-signedTheta, std::fmod(phi + 180.0, 360.0)};
}

namespace {

// The set's own direction when the angles name one (so the preview reproduces the stored
// values bit for bit), otherwise a direction built from the angles.
Direction pickDirection(const DirectionSet& set, double thetaDeg, double phiDeg) {
  for (const Direction& d : set.dirs())
    if (std::abs(rad2deg(d.theta) - thetaDeg) < 1e-6 &&
        (std::abs(std::remainder(rad2deg(d.phi) - phiDeg, 360.0)) < 1e-6 || d.theta == 0))
      return d;
  const DirectionPair p = pairFromDegrees(thetaDeg, phiDeg, thetaDeg, phiDeg);
  Direction d;
  d.theta = deg2rad(thetaDeg);
  d.phi = deg2rad(phiDeg);
  d.w = p.wi;
  return d;
}

std::string describePlan(const EffectPlan& p) {
  std::string s;
  for (const auto& d : p.decisions)
    s += d.effect + ": " + d.value + (d.forced ? " [forced] " : " — ") + d.reason + "\n";
  return s;
}

}  // namespace

void runPreview(const PreviewRequest& r, const CancelToken& cancel, const PreviewPublish& publish) {
  const auto t0 = Clock::now();
  auto since = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };
  const Scene scene = parseScene(r.sceneJson, r.source, r.baseDir);
  SimOptions o = optionsFromScene(scene);
  o.nu = o.nv = r.size;
  o.progress = false;
  // A direction set small enough for a live texel matrix.
  if (DirectionSet::fromName(o.directions).size() > 151) o.directions = "bonn81";
  SimulationJob job(scene, o);
  job.setCancel(&cancel);  // a superseded request stops even inside the network build
  const double setupSeconds = since();
  if (std::getenv("BTF_PREVIEW_TIMING"))
    std::fprintf(stderr, "preview: parse + geometry + BVH %.1f ms\n", setupSeconds * 1e3);
  const Direction view = pickDirection(job.directions(), r.thetaV, r.phiV);
  const Direction light = pickDirection(job.directions(), r.thetaL, r.phiL);
  auto image = [&](int n, bool indirect, const char* stage, bool final) {
    auto img = job.renderPair(view, light, n, n, indirect, &cancel);
    if (cancel.cancelled()) return false;
    const double s = since();
    if (std::getenv("BTF_PREVIEW_TIMING"))
      std::fprintf(stderr, "preview: %s (%d²) at %.1f ms\n", stage, n, s * 1e3);
    publish(
        [&](PreviewResult& res) {
          res.nu = res.nv = n;
          res.image = std::move(img);
          res.stage = stage;
          res.imageSeconds = s;
          res.imageFinal = final;
        });
    return true;
  };
  const int low = std::max(4, r.size / 4);
  if (low < r.size && !image(low, false, "direct light, quarter resolution", false)) return;
  if (!image(r.size, false, "direct light", false)) return;
  const EffectPlan& plan = job.plan();
  if (cancel.cancelled()) return;
  publish([&](PreviewResult& res) { res.plan = describePlan(plan); });
  const bool moreEffects = plan.interreflection || o.method == "pt";
  if (moreEffects && !image(r.size, true, "every effect of the plan", true)) return;
  if (!moreEffects) publish([&](PreviewResult& res) { res.imageFinal = true; });

  if (r.brdf) {
    const int G = std::max(4, r.brdfGrid);
    std::vector<DirectionPair> pairs;
    std::vector<std::array<double, 4>> deg;
    std::vector<int> pix;
    for (int j = 0; j < G; ++j)
      for (int i = 0; i < G; ++i) {
        const double x = (i + 0.5) / G * 2 - 1, y = (j + 0.5) / G * 2 - 1;
        const double rr = std::sqrt(x * x + y * y);
        if (rr >= 0.999) continue;
        double th = rad2deg(std::asin(rr)), ph = rad2deg(std::atan2(y, x));
        if (ph < 0) ph += 360;
        // Rounded to 1e-6 degrees so the printed pair reproduces exactly the same directions.
        th = std::round(th * 1e6) / 1e6;
        ph = std::round(ph * 1e6) / 1e6;
        deg.push_back({r.thetaL, r.phiL, th, ph});
        pairs.push_back(pairFromDegrees(r.thetaL, r.phiL, th, ph));
        pix.push_back(j * G + i);
      }
    std::vector<double> thetas;
    std::vector<DirectionPair> curvePairs;
    for (int k = -88; k <= 88; k += 4) {
      thetas.push_back(k);
      for (double off : {0.0, 90.0}) {
        const auto d = curveDirection(k, std::fmod(r.phiL + off, 360.0));
        curvePairs.push_back(pairFromDegrees(r.thetaL, r.phiL, d[0], d[1]));
      }
    }
    const int S = std::max(1, r.brdfSamples);
    auto vals = averagedBrdf(job.tracer(), job.materials(), pairs, S, o.seed, &cancel);
    if (cancel.cancelled()) return;
    auto curve = averagedBrdf(job.tracer(), job.materials(), curvePairs, S, o.seed, &cancel);
    if (cancel.cancelled()) return;
    if (std::getenv("BTF_PREVIEW_TIMING"))
      std::fprintf(stderr, "preview: BRDF slice (%zu + %zu pairs × %d) at %.1f ms\n", pairs.size(),
                   curvePairs.size(), S, since() * 1e3);
    publish(
        [&](PreviewResult& res) {
          res.brdfGrid = G;
          res.brdfSamples = S;
          res.brdfPairs = std::move(deg);
          res.brdfPixel = std::move(pix);
          res.brdfValues = std::move(vals);
          res.curveTheta = thetas;
          res.inPlane.clear();
          res.crossPlane.clear();
          for (size_t k = 0; k < thetas.size(); ++k) {
            res.inPlane.push_back(curve[2 * k]);
            res.crossPlane.push_back(curve[2 * k + 1]);
          }
        });
  }
  if (r.matrix) {
    const int u = r.texelU >= 0 ? std::min(r.texelU, r.size - 1) : r.size / 2;
    const int v = r.texelV >= 0 ? std::min(r.texelV, r.size - 1) : r.size / 2;
    auto m = job.evaluateTexels({int64_t(v) * r.size + u}, &cancel);
    if (cancel.cancelled() || m.empty()) return;
    if (std::getenv("BTF_PREVIEW_TIMING"))
      std::fprintf(stderr, "preview: texel matrix (%s) at %.1f ms\n", job.directions().name().c_str(),
                   since() * 1e3);
    publish(
        [&](PreviewResult& res) {
          res.texelU = u;
          res.texelV = v;
          res.matrixSet = job.directions().name();
          res.matrixDirsDeg.clear();
          for (const auto& d : job.directions().dirs())
            res.matrixDirsDeg.push_back({rad2deg(d.theta), rad2deg(d.phi)});
          res.matrix = std::move(m);
        });
  }
}

}  // namespace btf::ops
