// What the renderer's rooms share (internal to engine/btf/render): the small direction and
// index helpers, the camera of RenderScene and its pixel loop (renderWith), used by the flat,
// mapped and exact modes alike.
#pragma once
#include <btf/compress/cbtf.h>
#include <btf/compress/codec.h>
#include <btf/compress/mip.h>
#include <btf/core/error.h>
#include <btf/core/format.h>
#include <btf/core/run_context.h>
#include <btf/directions/direction_set.h>
#include <btf/geometry/tile_builder.h>
#include <btf/render/renderer.h>
#include <btf/store/btf_store.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>

namespace btf {
namespace renderdetail {

inline DVec3 fromAngles(double thetaDeg, double phiDeg) {
  const double t = deg2rad(thetaDeg), p = deg2rad(phiDeg);
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

inline int interp(const DirectionSet& dirs, const DVec3& w, DirWeight out[4]) {
  const double z = std::clamp(w.z, -1.0, 1.0);
  return dirs.interpolate(std::acos(z), std::atan2(w.y, w.x), out);
}

inline int64_t wrapIndex(double f, int n) {
  const int64_t i = int64_t(std::floor(f)) % n;
  return i < 0 ? i + n : i;
}

inline double cross2(const glm::dvec2& a, const glm::dvec2& b) {
  return a.x * b.y - a.y * b.x;
}

}  // namespace renderdetail

struct RenderScene::Camera {
  DVec3 pos, fwd, right, up;
  bool persp = false;
  double hw = 1, hh = 1;
  void ray(double sx, double sy, DVec3* o, DVec3* d) const {
    if (persp) {
      *o = pos;
      *d = glm::normalize(fwd + right * (sx * hw) + up * (sy * hh));
    } else {
      *o = pos + right * (sx * hw) + up * (sy * hh);
      *d = fwd;
    }
  }
};

template <class Shade>
RenderImage RenderScene::renderWith(const std::string& mode, const CancelToken* cancel,
                                    ProgressReporter* progress, Shade&& shade) const {
  const auto t0 = std::chrono::steady_clock::now();
  RenderImage img;
  img.mode = mode;
  img.width = m_s.width, img.height = m_s.height;
  img.rgb.assign(size_t(img.width) * size_t(img.height) * 3, 0.f);
  img.alpha.assign(size_t(img.width) * size_t(img.height), 0.f);
  img.lod.assign(img.alpha.size(), -1.f);
  img.footprintTexels.assign(img.alpha.size(), 0.f);
  const Camera cam = camera();
  std::atomic<uint64_t> rays{0};
  const int spp = std::max(1, m_s.spp);
  const double step = 2.0 / std::sqrt(double(spp));  // sample spacing in screen units × size
  const int grid = int(std::sqrt(double(spp)) + 1e-9);
  parallelForChunks(
      img.height, 1,
      [&](int64_t j0, int64_t j1) {
        uint64_t myRays = 0;
        for (int64_t j = j0; j < j1; ++j) {
          for (int i = 0; i < img.width; ++i) {
            const uint64_t pix = uint64_t(j) * uint64_t(img.width) + uint64_t(i);
            Rgb sum(0);
            int covered = 0, looked = 0;
            double lodSum = 0, texSum = 0;
            for (int s = 0; s < spp; ++s) {
              Rng rng(hashKeys(m_s.seed ^ 0x4e6d, pix, uint64_t(s)));
              // Stratified: the first g² samples jittered in a g × g grid over the pixel.
              double jx = 0.5, jy = 0.5;
              if (spp > 1) {
                jx = rng.uniformDouble(), jy = rng.uniformDouble();
                if (s < grid * grid) jx = (s % grid + jx) / grid, jy = (s / grid + jy) / grid;
              }
              const double sx = (i + jx) / img.width * 2 - 1;
              const double sy = 1 - (double(j) + jy) / img.height * 2;
              DVec3 o, d;
              cam.ray(sx, sy, &o, &d);
              // The neighbouring samples' rays, one sample spacing (a pixel / √spp) away.
              RayDiff diff;
              {
                DVec3 ox, dx, oy, dy;
                cam.ray(sx + step / img.width, sy, &ox, &dx);
                cam.ray(sx, sy - step / img.height, &oy, &dy);
                diff.dox = ox - o, diff.ddx = dx - d, diff.doy = oy - o, diff.ddy = dy - d;
              }
              Rgb c(0);
              SampleInfo info;
              if (shade(o, d, diff, rng, &c, &myRays, &info)) {
                ++covered;
                if (info.lod >= 0) lodSum += info.lod, texSum += info.texels, ++looked;
                if (std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z))
                  sum += glm::max(c, Rgb(0));
              }
            }
            for (int k = 0; k < 3; ++k) img.rgb[pix * 3 + size_t(k)] = sum[k] / float(spp);
            img.alpha[pix] = float(covered) / float(spp);
            img.lod[pix] = looked ? float(lodSum / looked) : -1.f;
            img.footprintTexels[pix] = looked ? float(texSum / looked) : 0.f;
          }
          if (progress) progress->add(1);
        }
        rays += myRays;
      },
      cancel);
  throwIfCancelled(cancel, "render");
  img.samples = uint64_t(img.width) * uint64_t(img.height) * uint64_t(spp);
  img.rays = rays.load();
  img.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return img;
}

}  // namespace btf
