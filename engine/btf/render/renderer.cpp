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

namespace {

DVec3 fromAngles(double thetaDeg, double phiDeg) {
  const double t = deg2rad(thetaDeg), p = deg2rad(phiDeg);
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

int interp(const DirectionSet& dirs, const DVec3& w, DirWeight out[4]) {
  const double z = std::clamp(w.z, -1.0, 1.0);
  return dirs.interpolate(std::acos(z), std::atan2(w.y, w.x), out);
}

int64_t wrapIndex(double f, int n) {
  const int64_t i = int64_t(std::floor(f)) % n;
  return i < 0 ? i + n : i;
}

double cross2(const glm::dvec2& a, const glm::dvec2& b) {
  return a.x * b.y - a.y * b.x;
}

}  // namespace

// ---------------------------------------------------------------------------------- sampler

namespace {
// Every direction's map of a raw store, one after the other; a damaged entry never reaches a
// pixel.
std::vector<float> vmfMaps(const BtfReader& r, int nDirs) {
  std::vector<float> all;
  all.reserve(size_t(nDirs) * size_t(r.info().texels()) * 2);
  for (int d = 0; d < nDirs; ++d) {
    std::vector<float> v = r.readVmf(d);
    for (float& x : v)
      if (!std::isfinite(x)) x = 0;
    all.insert(all.end(), v.begin(), v.end());
  }
  return all;
}
}  // namespace

BtfTile tileOfBtf(const BtfInfo& info, const std::string& path, uint64_t memoryBudget) {
  if (info.sceneJson.empty())
    throw Error(path + ": the file carries no scene, so the object's relief is unknown");
  BtfTile t;
  t.scene =
      parseScene(info.sceneJson, path + " (its scene)", std::filesystem::path(path).parent_path());
  t.geometry = buildTileGeometry(t.scene, memoryBudget);
  const TileGeometry& g = t.geometry;
  const float tiny = 1e-9f * float(std::max(g.Lx, g.Ly));
  t.flat = g.zmax - g.zmin <= tiny && std::abs(g.zmax) <= tiny;
  return t;
}

VmfTable readVmfTable(const std::string& vmfPath, const BtfInfo& I, const std::string& ofPath) {
  BtfReader r(vmfPath);
  const BtfInfo& V = r.info();
  if (V.nu != I.nu || V.nv != I.nv || V.directionSet != I.directionSet ||
      V.sceneHash != I.sceneHash)
    throw Error(
        format("%s: its visibility map does not belong to %s (texels %dx%d vs %dx%d, "
               "directions %s vs %s, scene %s vs %s)",
               vmfPath.c_str(), ofPath.c_str(), V.nu, V.nv, I.nu, I.nv, V.directionSet.c_str(),
               I.directionSet.c_str(), V.sceneHash.c_str(), I.sceneHash.c_str()));
  if (!V.hasVmf) throw Error(vmfPath + ": this BTF has no visibility map either");
  VmfTable t;
  t.nu = V.nu, t.nv = V.nv, t.nDirs = V.nDirs();
  t.map = vmfMaps(r, t.nDirs);
  const DirectionSet set = DirectionSet::fromName(V.directionSet);
  if (set.size() != t.nDirs)
    throw Error(vmfPath + ": the direction set of the file does not match its header");
  for (int d = 0; d < t.nDirs; ++d) t.dirZ.push_back(float(set[d].w.z));
  return t;
}

Rgb levelColour(double level) {
  static const Rgb ramp[6] = {{0.1f, 0.2f, 1.f}, {0.f, 0.9f, 0.9f}, {0.1f, 0.9f, 0.1f},
                              {1.f, 0.9f, 0.f},  {1.f, 0.15f, 0.f}, {0.9f, 0.f, 0.9f}};
  const double l = std::clamp(level, 0.0, 5.0);
  const int k = std::min(4, int(l));
  const float f = float(l - k);
  return (1 - f) * ramp[k] + f * ramp[k + 1];
}

BtfSampler::BtfSampler(const std::string& path, const std::string& vmfPath, bool flatTile,
                       uint64_t memoryBudget, const CancelToken* cancel, bool mip)
    : m_flat(flatTile) {
  const bool compressed = isCompressedFile(path);
  std::unique_ptr<Decoder> dec;
  std::shared_ptr<const Decoder> strip;  // a pyramid .cbtf: every level's texels
  BtfInfo base;
  if (compressed) {
    CompressedBtf c = readCompressed(path);
    if (!c.levels.empty()) {
      base = c.info;
      strip = makeDecoder(asStrip(std::move(c)));
      dec = pyramidLevel(strip, base, 0);
    } else {
      dec = makeDecoder(std::move(c));
    }
  } else {
    dec = openBtf(path);
  }
  const BtfInfo I = dec->info();
  m_dirs = std::make_shared<DirectionSet>(DirectionSet::fromName(I.directionSet));
  if (m_dirs->size() != I.nDirs())
    throw Error(path + ": the direction set of the file does not match its header");
  m_nu = I.nu, m_nv = I.nv, m_n = I.nDirs(), m_Lx = I.Lx, m_Ly = I.Ly;
  const size_t per = size_t(m_n) * size_t(m_n) * 3;
  const std::vector<MipLevel> L = mipLevels(I.nu, I.nv);
  const int K = mip ? int(L.size()) - 1 : 0;  // coarse levels wanted
  const uint64_t bytes = uint64_t(I.texels()) * I.texelBytes();
  const uint64_t coarseBytes = uint64_t(pyramidTexels(L) - I.texels()) * I.texelBytes();
  auto clean = [](float* p, size_t n) {
    for (size_t k = 0; k < n; ++k)
      if (!std::isfinite(p[k]) || p[k] < 0) p[k] = 0;
  };
  if (!compressed) {
    if (bytes + (K ? coarseBytes : 0) > memoryBudget)
      throw Error(format(
          "%s: its %.1f MiB of values%s exceed the memory budget (%.1f MiB); raise "
          "--memory-budget or render a compressed copy (.cbtf)",
          path.c_str(), double(bytes) / 1048576.0,
          K ? format(" and %.1f MiB of texel levels", double(coarseBytes) / 1048576.0).c_str() : "",
          double(memoryBudget) / 1048576.0));
    BtfReader r(path);
    m_data.resize(size_t(bytes / sizeof(float)));
    for (int c = 0; c < I.chunks(); ++c) {
      throwIfCancelled(cancel, "render");
      const std::vector<float> v = r.readChunk(c);  // checksum verified
      std::copy(v.begin(), v.end(),
                m_data.begin() + ptrdiff_t(uint64_t(I.chunkBegin(c)) * I.texelBytes() / 4));
    }
    clean(m_data.data(), m_data.size());
    if (I.hasVmf) m_vmf = vmfMaps(r, m_n);
  } else if (bytes + (K ? coarseBytes : 0) <= memoryBudget / 2) {
    // A compressed BTF is decoded whole when it fits (a render reads each value many times, and
    // a texel's decode shares its work across its values); per value through the decoder
    // otherwise.
    m_data.resize(size_t(bytes / sizeof(float)));
    parallelForChunks(
        I.texels(), 16,
        [&](int64_t t0, int64_t t1) {
          for (int64_t t = t0; t < t1; ++t) dec->texel(t, &m_data[size_t(t) * per]);
        },
        cancel);
    throwIfCancelled(cancel, "render");
    clean(m_data.data(), m_data.size());
  }
  m_lv.resize(size_t(K) + 1);
  m_lv[0].nu = m_nu, m_lv[0].nv = m_nv;
  m_lv[0].data = m_data.empty() ? nullptr : m_data.data();
  if (K > 0) {
    m_fileLevels = strip != nullptr;
    if (m_fileLevels) {
      // The file's own levels, decoded whole alongside level 0, or read per value.
      if (!m_data.empty()) m_coarse.resize(size_t(coarseBytes / sizeof(float)));
      for (int k = 1; k <= K; ++k) {
        auto lk = pyramidLevel(strip, base, k);
        if (m_data.empty()) {
          m_lv[size_t(k)].dec = std::move(lk);
          continue;
        }
        float* out = m_coarse.data() + size_t(L[size_t(k)].first - I.texels()) * per;
        parallelForChunks(
            L[size_t(k)].texels(), 16,
            [&](int64_t t0, int64_t t1) {
              for (int64_t t = t0; t < t1; ++t) lk->texel(t, out + size_t(t) * per);
            },
            cancel);
        throwIfCancelled(cancel, "render");
      }
      clean(m_coarse.data(), m_coarse.size());
    } else {
      if (m_data.empty())
        throw Error(
            format("%s: texel levels need its values decoded in memory (%.1f MiB with "
                   "the levels, over half the memory budget): raise --memory-budget, "
                   "compress it with --mip, or render with --filter point",
                   path.c_str(), double(bytes + coarseBytes) / 1048576.0));
      m_coarse = buildCoarseLevels(m_data.data(), I, K, cancel);
    }
    for (int k = 1; k <= K; ++k) {
      m_lv[size_t(k)].nu = L[size_t(k)].nu, m_lv[size_t(k)].nv = L[size_t(k)].nv;
      if (!m_coarse.empty())
        m_lv[size_t(k)].data = m_coarse.data() + size_t(L[size_t(k)].first - I.texels()) * per;
    }
  }
  m_lv[0].dec = std::move(dec);
  if (m_vmf.empty() && !vmfPath.empty()) m_vmf = readVmfTable(vmfPath, I, path).map;
  m_hasVmf = !m_vmf.empty();
  if (m_hasVmf && K > 0) {
    auto v = vmfLevels(m_vmf, m_n, m_nu, m_nv, K);
    for (int k = 1; k <= K; ++k) m_lv[size_t(k)].vmf = std::move(v[size_t(k - 1)]);
  }
}

BtfSampler::~BtfSampler() = default;

const BtfInfo& BtfSampler::info() const {
  return m_lv[0].dec->info();
}

uint64_t BtfSampler::memoryBytes() const {
  uint64_t n = m_data.size() + m_coarse.size() + m_vmf.size() + m_ambient.size();
  for (const Level& l : m_lv) n += l.vmf.size();
  return n * sizeof(float);
}

Rgb BtfSampler::value(int level, int64_t texel, int view, int light) const {
  const Level& L = m_lv[size_t(level)];
  if (L.data) {
    const float* p = L.data + size_t(((texel * m_n + view) * m_n + light) * 3);
    return {p[0], p[1], p[2]};
  }
  const auto v = L.dec->value(texel, view, light);
  return {v[0], v[1], v[2]};
}

template <class Fn>
void BtfSampler::bilinear(int level, double x, double y, Fn&& fn) const {
  // Texel centres at integer + ½ (in the level's texel units), periodic.
  const int nu = m_lv[size_t(level)].nu, nv = m_lv[size_t(level)].nv;
  const double fx = x / m_Lx * nu - 0.5, fy = y / m_Ly * nv - 0.5;
  const double x0 = std::floor(fx), y0 = std::floor(fy);
  const double ax = fx - x0, ay = fy - y0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const double w = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
      if (w > 0) fn(wrapIndex(x0 + i, nu) + int64_t(nu) * wrapIndex(y0 + j, nv), w);
    }
}

BtfSampler::Footprint BtfSampler::footprint(const glm::dvec2& dx, const glm::dvec2& dy,
                                            int maxAniso) const {
  Footprint f;
  if (levels() == 1) return f;
  // Lengths in level-0 texels; the rule is the GLSL decoder's too (texelFilter).
  const double la = glm::length(glm::dvec2(dx.x / m_Lx * m_nu, dx.y / m_Ly * m_nv));
  const double lb = glm::length(glm::dvec2(dy.x / m_Lx * m_nu, dy.y / m_Ly * m_nv));
  const TexelFilter t = texelFilter(la, lb, maxAniso, levels());
  f.lod = t.lod;
  f.na = t.na, f.nb = t.nb;
  if (std::isfinite(la) && std::isfinite(lb)) f.a = dx, f.b = dy;  // one tap: a, b unused
  return f;
}

template <class Fn>
void BtfSampler::filtered(double x, double y, const Footprint* fp, Fn&& fn) const {
  if (!fp || levels() == 1) {
    fn(0, x, y, 1.0);
    return;
  }
  const int top = levels() - 1;
  const double lod = std::clamp(fp->lod, 0.0, double(top));
  const int l0 = std::min(int(lod), top), l1 = std::min(l0 + 1, top);
  const double f = lod - l0;
  const int na = std::max(1, fp->na), nb = std::max(1, fp->nb);
  const double share = 1.0 / (double(na) * nb);
  for (int j = 0; j < nb; ++j)
    for (int i = 0; i < na; ++i) {
      const double sa = (i + 0.5) / na - 0.5, sb = (j + 0.5) / nb - 0.5;
      const double px = x + sa * fp->a.x + sb * fp->b.x, py = y + sa * fp->a.y + sb * fp->b.y;
      if (f < 1) fn(l0, px, py, (1 - f) * share);
      if (f > 0 && l1 != l0) fn(l1, px, py, f * share);
    }
}

Rgb BtfSampler::eval(double x, double y, const DVec3& wo, const DVec3& wi,
                     const Footprint* fp) const {
  DirWeight wv[4], wl[4];
  const int nv = interp(*m_dirs, wo, wv), nl = interp(*m_dirs, wi, wl);
  Rgb acc(0);
  filtered(x, y, fp, [&](int level, double px, double py, double lw) {
    bilinear(level, px, py, [&](int64_t t, double w) {
      for (int a = 0; a < nv; ++a)
        for (int b = 0; b < nl; ++b)
          acc += float(lw * w * wv[a].weight * wl[b].weight) *
                 value(level, t, wv[a].index, wl[b].index);
    });
  });
  return acc;
}

void BtfSampler::prepareAmbient(const CancelToken* cancel) {
  if (!m_ambient.empty()) return;
  size_t total = 0;
  for (Level& l : m_lv) {
    l.ambient = total;
    total += size_t(l.nu) * size_t(l.nv) * size_t(m_n) * 3;
  }
  m_ambient.assign(total, 0.f);
  // Each light direction weighs the cosine-weighted solid angle of its ring's band (edges
  // halfway to the neighbouring rings, 0° and 90° at the ends) shared by the ring's count:
  // π(sin²θhi − sin²θlo)/count — they sum to π, exactly the integral of a constant aBRDF.
  std::vector<double> lw(static_cast<size_t>(m_n), 0.0);
  const auto& rings = m_dirs->rings();
  for (size_t k = 0; k < rings.size(); ++k) {
    const double lo = k == 0 ? 0.0 : 0.5 * (rings[k - 1].theta + rings[k].theta);
    const double hi = k + 1 == rings.size() ? kPi / 2 : 0.5 * (rings[k].theta + rings[k + 1].theta);
    const double w =
        kPi * (std::sin(hi) * std::sin(hi) - std::sin(lo) * std::sin(lo)) / double(rings[k].count);
    for (int j = 0; j < rings[k].count; ++j) lw[size_t(rings[k].first + j)] = w;
  }
  const size_t per = size_t(m_n) * size_t(m_n) * 3;
  for (const Level& L : m_lv)
    parallelForChunks(
        int64_t(L.nu) * L.nv, 16,
        [&](int64_t t0, int64_t t1) {
          std::vector<float> buf(L.data ? 0 : per);
          for (int64_t t = t0; t < t1; ++t) {
            const float* px = nullptr;
            if (!L.data) {
              L.dec->texel(t, buf.data());
              px = buf.data();
            } else {
              px = L.data + size_t(t) * per;
            }
            for (int v = 0; v < m_n; ++v) {
              double acc[3] = {0, 0, 0};
              for (int l = 0; l < m_n; ++l)
                for (int c = 0; c < 3; ++c)
                  acc[c] += lw[size_t(l)] *
                            double(px[(size_t(v) * size_t(m_n) + size_t(l)) * 3 + size_t(c)]);
              for (int c = 0; c < 3; ++c)
                m_ambient[L.ambient + (size_t(t) * size_t(m_n) + size_t(v)) * 3 + size_t(c)] =
                    std::isfinite(acc[c]) ? float(std::max(acc[c], 0.0)) : 0.f;
            }
          }
        },
        cancel);
  throwIfCancelled(cancel, "render");
}

Rgb BtfSampler::ambient(double x, double y, const DVec3& wo, const Footprint* fp) const {
  DirWeight wv[4];
  const int nv = interp(*m_dirs, wo, wv);
  Rgb acc(0);
  filtered(x, y, fp, [&](int level, double px, double py, double lw) {
    const size_t base = m_lv[size_t(level)].ambient;
    bilinear(level, px, py, [&](int64_t t, double w) {
      for (int a = 0; a < nv; ++a) {
        const float* p = &m_ambient[base + (size_t(t) * size_t(m_n) + size_t(wv[a].index)) * 3];
        acc += float(lw * w * wv[a].weight) * Rgb(p[0], p[1], p[2]);
      }
    });
  });
  return acc;
}

void BtfSampler::vmf(double x, double y, const DVec3& w, float* coverage, float* height,
                     int level) const {
  if (!m_hasVmf) {  // a flat tile: the reference plane itself
    *coverage = 1, *height = 0;
    return;
  }
  level = std::clamp(level, 0, levels() - 1);
  const Level& L = m_lv[size_t(level)];
  const float* map = level == 0 ? m_vmf.data() : L.vmf.data();
  const int64_t t =
      wrapIndex(x / m_Lx * L.nu, L.nu) + int64_t(L.nu) * wrapIndex(y / m_Ly * L.nv, L.nv);
  const int64_t texels = int64_t(L.nu) * L.nv;
  double cov = 0, hs = 0;
  DirWeight ws[4];
  const int n = interp(*m_dirs, w, ws);
  for (int k = 0; k < n; ++k) {
    const DirWeight& d = ws[k];
    const float* p = map + size_t((int64_t(d.index) * texels + t) * 2);
    const double c = std::clamp(double(p[0]), 0.0, 1.0);
    cov += d.weight * c;
    hs += d.weight * c * double(p[1]) * (*m_dirs)[d.index].w.z;
  }
  *coverage = float(cov);
  *height = cov > 0 ? float(hs / cov) : 0.f;
}

// ---------------------------------------------------------------------------------- scene

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

RenderScene::RenderScene(ObjectMesh object, double Lx, double Ly, double zmin, double zmax,
                         const RenderSettings& s)
    : m_obj(std::move(object)), m_s(s), m_Lx(Lx), m_Ly(Ly) {
  if (!(s.tiling > 0)) throw Error("--tiling must be positive");
  if (!(s.reliefScale > 0)) throw Error("--relief-scale must be positive");
  if (m_obj.uv.size() != m_obj.pos.size() || m_obj.nrm.size() != m_obj.pos.size())
    throw Error("object " + m_obj.name + " has no texture coordinates on every vertex");
  const double R = m_obj.radius;
  m_k = m_obj.worldPerUv() / (s.tiling * Lx);
  m_K = m_k * s.reliefScale;
  const double pad = 1e-3 * std::max(Lx, Ly);
  m_hlo = zmin - pad, m_hhi = zmax + pad;
  m_eps = 2e-6 * R;
  m_light = lightDirection(s);
  const double T = s.tiling * Lx;  // tile units per uv unit

  // Weld vertices by position and normal: the shell's topology (seams keep their own uv).
  std::map<std::array<int64_t, 6>, uint32_t> weld;
  std::vector<uint32_t> wid(m_obj.pos.size());
  const double qp = 1e-6 * R, qn = 1e-5;
  for (size_t k = 0; k < m_obj.pos.size(); ++k) {
    const Vec3 p = m_obj.pos[k], n = m_obj.nrm[k];
    const std::array<int64_t, 6> key = {std::llround(p.x / qp), std::llround(p.y / qp),
                                        std::llround(p.z / qp), std::llround(n.x / qn),
                                        std::llround(n.y / qn), std::llround(n.z / qn)};
    auto [it, fresh] = weld.try_emplace(key, uint32_t(m_wpos.size()));
    if (fresh) m_wpos.push_back(p), m_wnrm.push_back(glm::normalize(n));
    wid[k] = it->second;
  }
  // Prisms over the non-degenerate base triangles; their tile axes.
  for (uint32_t t = 0; t < m_obj.tri.size(); ++t) {
    const auto& tr = m_obj.tri[t];
    Prism p;
    p.tri = t;
    for (int i = 0; i < 3; ++i) p.w[i] = wid[tr[i]], p.xy[i] = glm::dvec2(m_obj.uv[tr[i]]) * T;
    const DVec3 a(m_obj.pos[tr.x]), b(m_obj.pos[tr.y]), c(m_obj.pos[tr.z]);
    const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
    DVec3 tx(0), ty(0);
    if (p.w[0] != p.w[1] && p.w[1] != p.w[2] && p.w[0] != p.w[2] && area > 1e-12 * R * R) {
      const glm::dvec2 d1 = p.xy[1] - p.xy[0], d2 = p.xy[2] - p.xy[0];
      const double det = cross2(d1, d2);
      if (!(std::abs(det) > 1e-12 * T * T))
        throw Error(
            format("object %s: triangle %u has degenerate texture coordinates (uv (%g, %g), "
                   "(%g, %g), (%g, %g)); the renderer needs a texture map on every triangle",
                   m_obj.name.c_str(), t, m_obj.uv[tr.x].x, m_obj.uv[tr.x].y, m_obj.uv[tr.y].x,
                   m_obj.uv[tr.y].y, m_obj.uv[tr.z].x, m_obj.uv[tr.z].y));
      // [b−a c−a] = [∂P/∂x ∂P/∂y] · [d1 d2]
      tx = ((b - a) * d2.y - (c - a) * d1.y) / det;
      ty = ((c - a) * d1.x - (b - a) * d2.x) / det;
      m_prisms.push_back(p);
      m_baseKept.push_back(t);
    }
    m_triT.push_back(tx), m_triB.push_back(ty);
  }
  if (m_prisms.empty()) throw Error("object " + m_obj.name + " has no triangle with an area");
  // Per vertex, the relief's height scale: the local world length of a tile unit (area-weighted
  // over its triangles) × the relief scale, so a stretched texture map keeps the relief's
  // proportions where it lands.
  {
    std::vector<double> sum(m_wpos.size(), 0), wsum(m_wpos.size(), 0);
    for (const Prism& p : m_prisms) {
      const auto& tr = m_obj.tri[p.tri];
      const double aw = 0.5 * glm::length(glm::cross(DVec3(m_obj.pos[tr.y] - m_obj.pos[tr.x]),
                                                     DVec3(m_obj.pos[tr.z] - m_obj.pos[tr.x])));
      const double at = 0.5 * std::abs(cross2(p.xy[1] - p.xy[0], p.xy[2] - p.xy[0]));
      for (int i = 0; i < 3; ++i) sum[p.w[i]] += aw * std::sqrt(aw / at), wsum[p.w[i]] += aw;
    }
    m_wK.assign(m_wpos.size(), m_K);
    for (size_t w = 0; w < m_wpos.size(); ++w)
      if (wsum[w] > 0) m_wK[w] = sum[w] / wsum[w] * s.reliefScale;
  }

  // The shell may not fold: along every edge the offset surfaces at the bottom and top heights
  // must keep their orientation (1 + d·κ > 0, κ the normal's turn per length along the edge).
  double worst = 1;
  DVec3 worstAt(0);
  double worstR = 0;
  for (const Prism& p : m_prisms)
    for (int i = 0; i < 3; ++i) {
      const DVec3 pa(m_wpos[p.w[i]]), pb(m_wpos[p.w[(i + 1) % 3]]);
      const DVec3 na(m_wnrm[p.w[i]]), nb(m_wnrm[p.w[(i + 1) % 3]]);
      const double l2 = glm::dot(pb - pa, pb - pa);
      if (!(l2 > 0)) continue;
      const double kappa = glm::dot(nb - na, pb - pa) / l2;
      const double Kmax = std::max(m_wK[p.w[i]], m_wK[p.w[(i + 1) % 3]]);
      for (double h : {m_hlo, m_hhi}) {
        const double f = 1 + h * Kmax * kappa;
        if (f < worst) worst = f, worstAt = 0.5 * (pa + pb), worstR = 1 / std::abs(kappa);
      }
    }
  if (worst < 0.05)
    throw Error(
        format("relief scale %g with tiling %g makes the shell on %s fold over itself: the "
               "relief spans %.4g to %.4g world units along the normal but the surface's "
               "radius of curvature is only %.4g near (%.3f, %.3f, %.3f); lower "
               "--relief-scale or raise --tiling",
               s.reliefScale, s.tiling, m_obj.name.c_str(), m_hlo * m_K, m_hhi * m_K, worstR,
               worstAt.x, worstAt.y, worstAt.z));

  // Shell vertices: 2·w + level.
  std::vector<Vec3> sv(m_wpos.size() * 2);
  for (size_t w = 0; w < m_wpos.size(); ++w) {
    sv[2 * w] = Vec3(DVec3(m_wpos[w]) + DVec3(m_wnrm[w]) * (m_hlo * m_wK[w]));
    sv[2 * w + 1] = Vec3(DVec3(m_wpos[w]) + DVec3(m_wnrm[w]) * (m_hhi * m_wK[w]));
  }
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> edges;  // → first of the side's 2 faces
  std::vector<std::vector<int32_t>> attached;
  auto addFace = [&](uint32_t a, uint32_t b, uint32_t c, uint8_t kind) {
    Face f;
    f.v[0] = a, f.v[1] = b, f.v[2] = c, f.kind = kind;
    m_faces.push_back(f);
    attached.emplace_back();
    return uint32_t(m_faces.size() - 1);
  };
  for (int32_t pi = 0; pi < int32_t(m_prisms.size()); ++pi) {
    Prism& p = m_prisms[size_t(pi)];
    const uint32_t a = p.w[0], b = p.w[1], c = p.w[2];
    p.face[0] = addFace(2 * a + 1, 2 * b + 1, 2 * c + 1, 0);
    p.face[1] = addFace(2 * a, 2 * b, 2 * c, 1);
    attached[p.face[0]].push_back(pi);
    attached[p.face[1]].push_back(pi);
    for (int i = 0; i < 3; ++i) {
      const uint32_t u = p.w[i], v = p.w[(i + 1) % 3];
      const auto key = std::make_pair(std::min(u, v), std::max(u, v));
      auto it = edges.find(key);
      if (it == edges.end()) {
        const uint32_t f0 = addFace(2 * u, 2 * v, 2 * v + 1, 2);
        addFace(2 * u, 2 * v + 1, 2 * u + 1, 2);
        it = edges.emplace(key, f0).first;
      }
      p.face[2 + 2 * i] = it->second, p.face[3 + 2 * i] = it->second + 1;
      for (uint32_t f = it->second; f < it->second + 2; ++f) {
        if (attached[f].size() >= 2)
          throw Error(
              format("object %s is not a manifold: an edge near (%.3f, %.3f, %.3f) has more "
                     "than two triangles",
                     m_obj.name.c_str(), m_wpos[u].x, m_wpos[u].y, m_wpos[u].z));
        attached[f].push_back(pi);
      }
    }
  }
  for (Prism& p : m_prisms)
    for (int i = 0; i < 3; ++i) {
      const uint32_t u = p.w[i], v = p.w[(i + 1) % 3];
      const auto& at = attached[edges.at(std::make_pair(std::min(u, v), std::max(u, v)))];
      if (at.size() == 1) p.open |= uint8_t(1u << i);
      for (int32_t q : at)
        if (&m_prisms[size_t(q)] != &p) p.nb[i] = q;
    }
  for (size_t fi = 0; fi < m_faces.size(); ++fi) {
    Face& f = m_faces[fi];
    const DVec3 a(sv[f.v[0]]), b(sv[f.v[1]]), c(sv[f.v[2]]);
    f.n = glm::cross(b - a, c - a);
    const DVec3 fc = (a + b + c) / 3.0;
    for (int32_t pi : attached[fi]) {
      const Prism& p = m_prisms[size_t(pi)];
      DVec3 pc(0);
      for (int i = 0; i < 3; ++i) pc += DVec3(sv[2 * p.w[i]]) + DVec3(sv[2 * p.w[i] + 1]);
      const int side = glm::dot(pc / 6.0 - fc, f.n) >= 0 ? 0 : 1;
      if (f.prism[side] >= 0)
        throw Error(
            format("the shell on %s folds over itself near (%.3f, %.3f, %.3f): lower "
                   "--relief-scale or raise --tiling",
                   m_obj.name.c_str(), fc.x, fc.y, fc.z));
      f.prism[side] = pi;
    }
  }
  m_sv.assign(sv.begin(), sv.end());
  std::vector<glm::uvec3> ft(m_faces.size());
  for (size_t k = 0; k < m_faces.size(); ++k)
    ft[k] = {m_faces[k].v[0], m_faces[k].v[1], m_faces[k].v[2]};
  m_shell = std::make_unique<MeshTracer>(sv, ft);
  std::vector<glm::uvec3> bt;
  for (uint32_t t : m_baseKept) bt.push_back(m_obj.tri[t]);
  m_base = std::make_unique<MeshTracer>(m_obj.pos, bt);
}

RenderScene::~RenderScene() = default;

CameraFrame cameraFrame(const RenderSettings& s, double R) {
  CameraFrame c;
  const DVec3 toCam = fromAngles(s.camTheta, s.camPhi);
  c.fwd = -toCam;
  const DVec3 hint = std::abs(toCam.z) > 0.999 ? DVec3(0, 1, 0) : DVec3(0, 0, 1);
  c.right = glm::normalize(glm::cross(c.fwd, hint));
  c.up = glm::cross(c.right, c.fwd);
  const double aspect = double(s.width) / double(s.height);
  c.perspective = s.perspective;
  if (c.perspective) {
    const double half = deg2rad(std::clamp(s.fovDeg, 1.0, 170.0)) / 2;
    const double dist = std::max(1.05 * R / std::sin(half) / s.zoom, 1.01 * R);
    c.pos = toCam * dist;
    c.hh = std::tan(half), c.hw = c.hh * aspect;
  } else {
    c.pos = toCam * (4 * R);
    c.hh = 1.05 * R / s.zoom, c.hw = c.hh * aspect;
  }
  return c;
}

DVec3 lightDirection(const RenderSettings& s) {
  return fromAngles(s.lightTheta, s.lightPhi);
}

RenderScene::Camera RenderScene::camera() const {
  const CameraFrame f = cameraFrame(m_s, m_obj.radius);
  Camera c;
  c.pos = f.pos, c.fwd = f.fwd, c.right = f.right, c.up = f.up;
  c.persp = f.perspective, c.hw = f.hw, c.hh = f.hh;
  return c;
}

DVec3 RenderScene::tileCoords(const Face& f, int prism, float bu, float bv) const {
  const Prism& p = m_prisms[size_t(prism)];
  const double w[3] = {1.0 - double(bu) - double(bv), double(bu), double(bv)};
  DVec3 r(0);
  for (int k = 0; k < 3; ++k) {
    const uint32_t wv = f.v[k] >> 1;
    const double h = (f.v[k] & 1) ? m_hhi : m_hlo;
    int i = 0;
    while (i < 2 && p.w[i] != wv) ++i;
    r += w[k] * DVec3(p.xy[i].x, p.xy[i].y, h);
  }
  return r;
}

void RenderScene::frameOf(uint32_t baseTri, const DVec3& n, DVec3* t, DVec3* b) const {
  DVec3 tx = m_triT[baseTri] - n * glm::dot(n, m_triT[baseTri]);
  double l = glm::length(tx);
  if (!(l > 1e-12)) {
    tx = std::abs(n.x) < 0.9 ? DVec3(1, 0, 0) : DVec3(0, 1, 0);
    tx -= n * glm::dot(n, tx);
    l = glm::length(tx);
  }
  *t = tx / l;
  *b = glm::cross(n, *t);
  if (glm::dot(*b, m_triB[baseTri]) < 0) *b = -*b;  // mirrored texture map
}

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

void RenderScene::SampleInfo::set(const BtfSampler::Footprint& fp, const BtfSampler& btf) {
  lod = fp.lod;
  // |a × b| in level-0 texels (a point lookup: one texel).
  const BtfInfo& I = btf.info();
  const double sx = I.nu / I.Lx, sy = I.nv / I.Ly;
  texels = std::abs(fp.a.x * sx * fp.b.y * sy - fp.a.y * sy * fp.b.x * sx);
}

BtfSampler::Footprint RenderScene::footprintAt(uint32_t tri, const DVec3& p, const DVec3& o,
                                               const DVec3& d, const RayDiff& diff,
                                               const BtfSampler& btf) const {
  BtfSampler::Footprint fp;
  if (m_s.forceLevel >= 0) {
    fp.lod = std::min(m_s.forceLevel, btf.levels() - 1);
    return fp;
  }
  // The neighbours' rays meet the triangle's plane at p + dp (tangent-plane transfer, Igehy's
  // ray differentials); the triangle's texture map turns dp into tile units.
  const auto& tr = m_obj.tri[tri];
  const DVec3 p0(m_obj.pos[tr.x]), e1 = DVec3(m_obj.pos[tr.y]) - p0,
                                   e2 = DVec3(m_obj.pos[tr.z]) - p0;
  const glm::dvec2 t0(m_obj.uv[tr.x]), q1 = glm::dvec2(m_obj.uv[tr.y]) - t0,
                                       q2 = glm::dvec2(m_obj.uv[tr.z]) - t0;
  const double det = q1.x * q2.y - q1.y * q2.x;
  const DVec3 n = glm::cross(e1, e2);
  const double T = m_s.tiling * m_Lx;
  auto transfer = [&](const DVec3& dox, const DVec3& ddx) -> glm::dvec2 {
    const DVec3 o2 = o + dox, d2 = d + ddx;
    const double den = glm::dot(d2, n);
    if (!(std::abs(den) > 1e-300) || !(std::abs(det) > 1e-300))
      return glm::dvec2(std::numeric_limits<double>::infinity());
    const DVec3 dp = o2 + d2 * (glm::dot(p - o2, n) / den) - p;
    // dp = α e1 + β e2 in the plane; (du, dv) = α q1 + β q2.
    const double g11 = glm::dot(e1, e1), g12 = glm::dot(e1, e2), g22 = glm::dot(e2, e2);
    const double r1 = glm::dot(dp, e1), r2 = glm::dot(dp, e2), gd = g11 * g22 - g12 * g12;
    if (!(gd > 0)) return glm::dvec2(std::numeric_limits<double>::infinity());
    const double a = (r1 * g22 - r2 * g12) / gd, b = (r2 * g11 - r1 * g12) / gd;
    return (a * q1 + b * q2) * T;
  };
  const glm::dvec2 dx = transfer(diff.dox, diff.ddx), dy = transfer(diff.doy, diff.ddy);
  if (m_s.mip && btf.levels() > 1) return btf.footprint(dx, dy, m_s.maxAniso);
  if (std::isfinite(dx.x + dx.y + dy.x + dy.y)) fp.a = dx, fp.b = dy;  // one tap, level 0
  return fp;
}

RenderImage RenderScene::renderFlat(const BtfSampler& btf, const CancelToken* cancel,
                                    ProgressReporter* progress) const {
  const double T = m_s.tiling * m_Lx;
  const float E = float(m_s.irradiance), Lenv = float(m_s.environment);
  RenderImage img = renderWith(
      "flat", cancel, progress,
      [&](const DVec3& o, const DVec3& d, const RayDiff& diff, Rng&, Rgb* out, uint64_t* rays,
          SampleInfo* info) {
        const MeshHit h = m_base->intersect(o, d);
        ++*rays;
        if (!h.hit()) return false;
        const uint32_t t = m_baseKept[h.prim];
        const auto& tr = m_obj.tri[t];
        const double b[3] = {1.0 - h.u - h.v, h.u, h.v};
        DVec3 n(0), ng;
        glm::dvec2 uv(0);
        for (int k = 0; k < 3; ++k)
          n += b[k] * DVec3(m_obj.nrm[tr[k]]), uv += b[k] * glm::dvec2(m_obj.uv[tr[k]]);
        n = glm::normalize(n);
        ng = glm::normalize(glm::cross(DVec3(m_obj.pos[tr.y] - m_obj.pos[tr.x]),
                                       DVec3(m_obj.pos[tr.z] - m_obj.pos[tr.x])));
        if (glm::dot(ng, n) < 0) ng = -ng;
        if (glm::dot(n, -d) <= 0) return true;  // the back of the surface: black
        DVec3 tx, ty;
        frameOf(t, n, &tx, &ty);
        const DVec3 wo(glm::dot(-d, tx), glm::dot(-d, ty), glm::dot(-d, n));
        const DVec3 wi(glm::dot(m_light, tx), glm::dot(m_light, ty), glm::dot(m_light, n));
        if (wo.z <= 0) return true;
        const DVec3 p = o + d * h.t;
        const BtfSampler::Footprint fp = footprintAt(t, p, o, d, diff, btf);
        info->set(fp, btf);
        if (m_s.showLevel) {
          *out = levelColour(fp.lod);
          return true;
        }
        if (Lenv > 0) *out += Lenv * btf.ambient(uv.x * T, uv.y * T, glm::normalize(wo), &fp);
        if (wi.z <= 0 || !(E > 0)) return true;
        ++*rays;
        if (m_base->occluded(p + ng * m_eps, m_light, m_eps)) return true;
        *out += E * float(wi.z) *
                btf.eval(uv.x * T, uv.y * T, glm::normalize(wo), glm::normalize(wi), &fp);
        return true;
      });
  img.triangles = m_baseKept.size();
  return img;
}

bool RenderScene::onObject(int p, glm::dvec2 x) const {
  for (int step = 0; step < 16; ++step) {
    const Prism& P = m_prisms[size_t(p)];
    const double det = cross2(P.xy[1] - P.xy[0], P.xy[2] - P.xy[0]);
    int worstEdge = -1;
    double worst = -1e-9;
    for (int k = 0; k < 3; ++k) {
      const double b = cross2(P.xy[(k + 2) % 3] - P.xy[(k + 1) % 3], x - P.xy[(k + 1) % 3]) / det;
      if (b < worst) worst = b, worstEdge = (k + 1) % 3;  // edge (k+1, k+2) is edge index k+1
    }
    if (worstEdge < 0) return true;
    if (P.open & (1u << worstEdge)) return false;
    const int q = P.nb[worstEdge];
    if (q < 0) return false;
    // Into the neighbour's coordinates (they differ by whole periods across a seam).
    const Prism& Q = m_prisms[size_t(q)];
    const uint32_t shared = P.w[worstEdge];
    int iq = 0;
    while (iq < 2 && Q.w[iq] != shared) ++iq;
    x += Q.xy[iq] - P.xy[worstEdge];
    p = q;
  }
  return true;  // far from any edge it could cross: accept
}

DVec3 RenderScene::tileDir(int prism, const DVec3& t, const DVec3& d) const {
  // Directions live in the orthonormal frame of the point (the interpolated normal, the tile's
  // x axis projected): the BTF was simulated on an undistorted tile, so a stretched texture map
  // changes where texels land (positions follow the prism map), not the angles.
  const Prism& P = m_prisms[size_t(prism)];
  const glm::dvec2 e1 = P.xy[1] - P.xy[0], e2 = P.xy[2] - P.xy[0];
  const double det = cross2(e1, e2);
  const glm::dvec2 x(t.x, t.y);
  const double b1 = cross2(x - P.xy[0], e2) / det, b2 = cross2(e1, x - P.xy[0]) / det;
  DVec3 n = (1 - b1 - b2) * DVec3(m_wnrm[P.w[0]]) + b1 * DVec3(m_wnrm[P.w[1]]) +
            b2 * DVec3(m_wnrm[P.w[2]]);
  const double l = glm::length(n);
  n = l > 0 ? n / l : DVec3(m_wnrm[P.w[0]]);
  DVec3 tx, ty;
  frameOf(P.tri, n, &tx, &ty);
  const DVec3 v(glm::dot(d, tx), glm::dot(d, ty), glm::dot(d, n));
  const double lv = glm::length(v);
  return lv > 0 ? v / lv : DVec3(0, 0, 1);
}

bool RenderScene::segmentHit(int prism, const DVec3& tin, const DVec3& tout, const DVec3& pin,
                             const DVec3& pout, const DVec3& d, const BtfSampler& btf, Rng& rng,
                             bool* ahead, MarchHit* hit, int vmfLevel) const {
  // The view direction in tile space from the prism map's Jacobian at the segment's middle
  // (the chord between entry and exit is ill-conditioned in a thin shell).
  const DVec3 w = tileDir(prism, 0.5 * (tin + tout), -d);
  if (!(w.z > 1e-9)) return false;          // rising or level in tile space: the VMF has no answer
  const DVec3 c = tin - (tin.z / w.z) * w;  // the line's crossing of the reference plane
  float cov, zh;
  btf.vmf(c.x, c.y, w, &cov, &zh, vmfLevel);
  if (!(cov > 0)) return false;
  const double lo = std::min(tin.z, tout.z), hi = std::max(tin.z, tout.z);
  // The hit must lie within this segment's heights. Below, it is a later prism's (and `ahead`
  // records that a line has put it further on). Above, the line meets relief behind the
  // segment: when an earlier line had put the hit ahead, the hit lies at the junction of the two
  // (the surface's curvature bent the ray between them) and is taken at the entry; otherwise the
  // ray's path through the earlier prisms passed over it — a grazing ray at a silhouette passes
  // over relief that this straight line would meet.
  if (double(zh) < lo - 1e-9) {
    *ahead = true;
    return false;
  }
  if (double(zh) > hi + 1e-9 && !*ahead) return false;
  if (cov < 1 && rng.uniform() >= cov) return false;
  // The exact object ends at its boundary edges (its micro-geometry is clipped there): a relief
  // point beyond the object's texture domain is not on the object.
  const DVec3 at = c + (double(zh) / w.z) * w;
  if (!onObject(prism, glm::dvec2(at.x, at.y))) return false;
  const double zc = std::min(double(zh), hi);
  const double dz = tin.z - tout.z;
  const double s = dz > 1e-12 ? std::clamp((tin.z - zc) / dz, 0.0, 1.0) : 0.0;
  hit->tile = tin + s * (tout - tin);
  hit->world = pin + s * (pout - pin);
  hit->crossing = DVec3(c.x, c.y, 0);
  hit->wo = w;
  return true;
}

bool RenderScene::nextFace(int prism, const DVec3& o, const DVec3& d, double tmin,
                           MeshHit* h) const {
  const Prism& P = m_prisms[size_t(prism)];
  constexpr double kEdge = 1e-9;  // a hair of overlap on the edges: no leak between triangles
  double best = std::numeric_limits<double>::infinity();
  for (uint32_t fi : P.face) {
    const Face& f = m_faces[fi];
    const DVec3& v0 = m_sv[f.v[0]];
    const DVec3 e1 = m_sv[f.v[1]] - v0, e2 = m_sv[f.v[2]] - v0;
    const DVec3 pv = glm::cross(d, e2);
    const double det = glm::dot(e1, pv);
    if (!(std::abs(det) > 0)) continue;
    const double inv = 1 / det;
    const DVec3 tv = o - v0;
    const double u = glm::dot(tv, pv) * inv;
    if (u < -kEdge || u > 1 + kEdge) continue;
    const DVec3 qv = glm::cross(tv, e1);
    const double v = glm::dot(d, qv) * inv;
    if (v < -kEdge || u + v > 1 + kEdge) continue;
    const double t = glm::dot(e2, qv) * inv;
    if (t > tmin && t < best) {
      best = t;
      h->prim = fi, h->t = t;
      h->u = float(std::clamp(u, 0.0, 1.0)), h->v = float(std::clamp(v, 0.0, 1.0 - h->u));
    }
  }
  return std::isfinite(best);
}

RenderScene::MarchResult RenderScene::march(const DVec3& o, const DVec3& d, double tmin,
                                            const BtfSampler& btf, Rng& rng, MarchHit* hit,
                                            uint64_t* rays, const RayDiff* diff) const {
  double tnear = tmin;
  int cur = -1;
  bool ahead = false;
  // The VMF's level: the footprint's where the camera ray enters the shell (rounded down: the
  // silhouette keeps the finest detail the footprint resolves); level 0 for light rays.
  int vmfLevel = m_s.forceLevel >= 0 ? m_s.forceLevel : 0;
  BtfSampler::Footprint fp;
  if (m_s.forceLevel >= 0) fp.lod = m_s.forceLevel;
  DVec3 tin(0), pin(0);
  for (int step = 0; step < 1 << 16; ++step) {
    MeshHit h;
    if (cur < 0 || !nextFace(cur, o, d, tnear, &h)) {
      h = m_shell->intersect(o, d, tnear);
      ++*rays;
      if (!h.hit()) return kMiss;
    }
    const Face& f = m_faces[h.prim];
    const bool intoFront = glm::dot(d, f.n) > 0;
    const int from = f.prism[intoFront ? 1 : 0], to = f.prism[intoFront ? 0 : 1];
    const DVec3 p = o + d * h.t;
    if (from >= 0 && from == cur) {
      const DVec3 tout = tileCoords(f, from, h.u, h.v);
      if (segmentHit(from, tin, tout, pin, p, d, btf, rng, &ahead, hit, vmfLevel)) {
        hit->prism = from;
        hit->fp = fp;
        return kRelief;
      }
    }
    if (to >= 0) {
      if (cur < 0 && f.kind == 1) return kAbsorbed;  // from inside the object: its underside
      if (cur < 0) ahead = false;                    // entering the shell from outside
      if (cur < 0 && diff && m_s.forceLevel < 0) {
        fp = footprintAt(m_prisms[size_t(to)].tri, p, o, d, *diff, btf);
        vmfLevel = int(fp.lod);
      }
      cur = to, tin = tileCoords(f, to, h.u, h.v), pin = p;
    } else {
      cur = -1;
    }
    tnear = h.t + m_eps;
  }
  return kMiss;
}

bool RenderScene::lightAt(const MarchHit& hit, const BtfSampler& btf, Rng& rng, DVec3* wi,
                          uint64_t* rays) const {
  // Out of the shell toward the light; the direction is the light's in the tile space of the
  // prism where the ray leaves (its Jacobian at the exit point).
  const DVec3 o = hit.world, L = m_light;
  int cur = hit.prism;
  double tnear = m_eps;
  for (int step = 0; step < 1 << 16; ++step) {
    MeshHit h;
    if (!nextFace(cur, o, L, tnear, &h)) {
      h = m_shell->intersect(o, L, tnear);
      ++*rays;
    }
    if (!h.hit()) {
      // Only when the hit point was placed a hair outside the shell (it is interpolated along
      // the camera's segment): the light leaves from the hit's own prism.
      const DVec3 w = tileDir(hit.prism, hit.tile, L);
      if (!(w.z > 0)) return false;
      *wi = w;
      return true;
    }
    const Face& f = m_faces[h.prim];
    const bool intoFront = glm::dot(L, f.n) > 0;
    const int from = f.prism[intoFront ? 1 : 0], to = f.prism[intoFront ? 0 : 1];
    if (to < 0) {
      if (f.kind == 1) return false;  // into the object: the light is behind it
      const int last = from >= 0 ? from : cur;
      if (last < 0) return false;
      const DVec3 w = tileDir(last, tileCoords(f, last, h.u, h.v), L);
      if (!(w.z > 0)) return false;
      MarchHit other;
      const MarchResult m = march(o, L, h.t + m_eps, btf, rng, &other, rays);
      if (m != kMiss) return false;  // another part of the object casts its shadow
      *wi = w;
      return true;
    }
    cur = to;
    tnear = h.t + m_eps;
  }
  return false;
}

RenderImage RenderScene::renderMapped(const BtfSampler& btf, const CancelToken* cancel,
                                      ProgressReporter* progress) const {
  const float E = float(m_s.irradiance), Lenv = float(m_s.environment);
  RenderImage img = renderWith(
      "mapped", cancel, progress,
      [&](const DVec3& o, const DVec3& d, const RayDiff& diff, Rng& rng, Rgb* out, uint64_t* rays,
          SampleInfo* info) {
        MarchHit hit;
        const MarchResult m = march(o, d, 0.0, btf, rng, &hit, rays, &diff);
        if (m == kMiss) return false;
        if (m == kAbsorbed) return true;
        info->set(hit.fp, btf);
        if (m_s.showLevel) {
          *out = levelColour(hit.fp.lod);
          return true;
        }
        if (Lenv > 0) *out += Lenv * btf.ambient(hit.crossing.x, hit.crossing.y, hit.wo, &hit.fp);
        DVec3 wi;
        if (!(E > 0) || !lightAt(hit, btf, rng, &wi, rays)) return true;
        *out += E * float(wi.z) * btf.eval(hit.crossing.x, hit.crossing.y, hit.wo, wi, &hit.fp);
        return true;
      });
  img.triangles = m_faces.size();
  return img;
}

// ---------------------------------------------------------------------------------- exact

namespace {

struct ExactMesh {
  std::vector<Vec3> pos, nrm;
  std::vector<glm::uvec3> tri;
  std::vector<uint16_t> mat;
  std::vector<uint32_t> base;
};

struct ClipVertex {
  DVec3 p;  // tile space
  DVec3 n;  // tile-frame normal
};

}  // namespace

uint64_t RenderScene::exactTriangleEstimate(const TileGeometry& tile) const {
  // Micro triangle i (extent s_i) lands in every prism p whose tile-space triangle its box meets:
  // at most (√A_p + s_i)²/(Lx·Ly) copies (the Minkowski sum of two boxes), each clipped piece a
  // fan of triangles. Summed: (n·ΣA_p + 2·Σ√A_p·Σs_i + P·Σs_i²)/(Lx·Ly), times 0.45: the boxes
  // overstate a triangle's reach; measured on brick at tiling 6 (vase, sphere, section) the
  // result is 0.95–1.2× the triangles built. The build checks the real count against the budget
  // too.
  const auto& M = tile.mesh;
  double s1 = 0, s2 = 0;
  for (const auto& t : M.tri) {
    const Vec3 a = M.pos[t.x], b = M.pos[t.y], c = M.pos[t.z];
    const double si = std::max(std::max({a.x, b.x, c.x}) - std::min({a.x, b.x, c.x}),
                               std::max({a.y, b.y, c.y}) - std::min({a.y, b.y, c.y}));
    s1 += si, s2 += si * si;
  }
  double area = 0, roots = 0;
  for (const Prism& p : m_prisms) {
    const double A = 0.5 * std::abs(cross2(p.xy[1] - p.xy[0], p.xy[2] - p.xy[0]));
    area += A, roots += std::sqrt(A);
  }
  const double n = double(M.tri.size()), P = double(m_prisms.size());
  return uint64_t(0.45 * (n * area + 2 * roots * s1 + P * s2) / (m_Lx * m_Ly)) + m_prisms.size();
}

RenderImage RenderScene::renderExact(const TileGeometry& tile,
                                     const std::vector<Material>& materials, uint64_t maxTriangles,
                                     const CancelToken* cancel, ProgressReporter* progress) const {
  const auto tBuild = std::chrono::steady_clock::now();
  const uint64_t estimate = exactTriangleEstimate(tile);
  if (estimate > maxTriangles)
    throw Error(
        format("the exact object would hold about %llu triangles (%zu per tile, tiling %g); "
               "the memory budget allows %llu: lower --tiling or raise --memory-budget",
               (unsigned long long)estimate, tile.triangleCount(), m_s.tiling,
               (unsigned long long)maxTriangles));
  const auto& M = tile.mesh;
  // Micro triangles binned on a grid over their tile-space bounds.
  double gx0 = 1e300, gx1 = -1e300, gy0 = 1e300, gy1 = -1e300;
  for (const Vec3& p : M.pos)
    gx0 = std::min(gx0, double(p.x)), gx1 = std::max(gx1, double(p.x)),
    gy0 = std::min(gy0, double(p.y)), gy1 = std::max(gy1, double(p.y));
  const int G = std::clamp(int(std::sqrt(double(M.tri.size()) / 4)), 1, 256);
  const double cw = std::max(gx1 - gx0, 1e-12) / G, ch = std::max(gy1 - gy0, 1e-12) / G;
  std::vector<std::vector<uint32_t>> cells(size_t(G) * size_t(G));
  auto cellRange = [&](double x0, double x1, double y0, double y1, int* i0, int* i1, int* j0,
                       int* j1) {
    *i0 = std::clamp(int(std::floor((x0 - gx0) / cw)), 0, G - 1);
    *i1 = std::clamp(int(std::floor((x1 - gx0) / cw)), 0, G - 1);
    *j0 = std::clamp(int(std::floor((y0 - gy0) / ch)), 0, G - 1);
    *j1 = std::clamp(int(std::floor((y1 - gy0) / ch)), 0, G - 1);
  };
  std::vector<std::array<double, 4>> tbox(M.tri.size());
  for (uint32_t t = 0; t < M.tri.size(); ++t) {
    const Vec3 a = M.pos[M.tri[t].x], b = M.pos[M.tri[t].y], c = M.pos[M.tri[t].z];
    tbox[t] = {std::min({a.x, b.x, c.x}) * 1.0, std::max({a.x, b.x, c.x}) * 1.0,
               std::min({a.y, b.y, c.y}) * 1.0, std::max({a.y, b.y, c.y}) * 1.0};
    int i0, i1, j0, j1;
    cellRange(tbox[t][0], tbox[t][1], tbox[t][2], tbox[t][3], &i0, &i1, &j0, &j1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) cells[size_t(j) * size_t(G) + size_t(i)].push_back(t);
  }
  // Every prism clips the tile instances that overlap it (per-prism outputs, joined in order).
  std::vector<ExactMesh> parts(m_prisms.size());
  parallelForChunks(
      int64_t(m_prisms.size()), 16,
      [&](int64_t b0, int64_t b1) {
        std::vector<uint32_t> stamp(M.tri.size(), 0xffffffffu);
        uint32_t stampId = 0;
        std::vector<ClipVertex> poly, next;
        for (int64_t pi = b0; pi < b1; ++pi) {
          const Prism& P = m_prisms[size_t(pi)];
          ExactMesh& out = parts[size_t(pi)];
          const glm::dvec2* q = P.xy;
          const double area2 = cross2(q[1] - q[0], q[2] - q[0]);
          const double orient = area2 > 0 ? 1 : -1;
          const double bx0 = std::min({q[0].x, q[1].x, q[2].x}),
                       bx1 = std::max({q[0].x, q[1].x, q[2].x});
          const double by0 = std::min({q[0].y, q[1].y, q[2].y}),
                       by1 = std::max({q[0].y, q[1].y, q[2].y});
          DVec3 W[3], N[3];
          for (int k = 0; k < 3; ++k) W[k] = DVec3(m_wpos[P.w[k]]), N[k] = DVec3(m_wnrm[P.w[k]]);
          const int ia = int(std::floor((bx0 - gx1) / m_Lx)),
                    ib = int(std::ceil((bx1 - gx0) / m_Lx));
          const int ja = int(std::floor((by0 - gy1) / m_Ly)),
                    jb = int(std::ceil((by1 - gy0) / m_Ly));
          for (int jj = ja; jj <= jb; ++jj)
            for (int ii = ia; ii <= ib; ++ii) {
              const double ox = ii * m_Lx, oy = jj * m_Ly;
              const double rx0 = std::max(bx0 - ox, gx0), rx1 = std::min(bx1 - ox, gx1);
              const double ry0 = std::max(by0 - oy, gy0), ry1 = std::min(by1 - oy, gy1);
              if (rx0 > rx1 || ry0 > ry1) continue;
              ++stampId;
              int i0, i1, j0, j1;
              cellRange(rx0, rx1, ry0, ry1, &i0, &i1, &j0, &j1);
              for (int cj = j0; cj <= j1; ++cj)
                for (int ci = i0; ci <= i1; ++ci)
                  for (uint32_t t : cells[size_t(cj) * size_t(G) + size_t(ci)]) {
                    if (stamp[t] == stampId) continue;
                    stamp[t] = stampId;
                    const auto& bb = tbox[t];
                    if (bb[1] < rx0 || bb[0] > rx1 || bb[3] < ry0 || bb[2] > ry1) continue;
                    poly.clear();
                    for (int k = 0; k < 3; ++k) {
                      const uint32_t v = M.tri[t][k];
                      poly.push_back({DVec3(M.pos[v]) + DVec3(ox, oy, 0),
                                      M.nrm.empty() ? DVec3(0, 0, 1) : DVec3(M.nrm[v])});
                    }
                    for (int e = 0; e < 3 && poly.size() >= 3; ++e) {
                      const glm::dvec2 a = q[e], b = q[(e + 1) % 3];
                      auto side = [&](const DVec3& p) {
                        return orient * cross2(b - a, glm::dvec2(p.x, p.y) - a);
                      };
                      next.clear();
                      for (size_t k = 0; k < poly.size(); ++k) {
                        const ClipVertex& A = poly[k];
                        const ClipVertex& B = poly[(k + 1) % poly.size()];
                        const double sa = side(A.p), sb = side(B.p);
                        if (sa >= 0) next.push_back(A);
                        if ((sa >= 0) != (sb >= 0)) {
                          const double s = sa / (sa - sb);
                          next.push_back({A.p + s * (B.p - A.p), A.n + s * (B.n - A.n)});
                        }
                      }
                      poly.swap(next);
                    }
                    if (poly.size() < 3) continue;

                    const uint32_t first = uint32_t(out.pos.size());
                    for (const ClipVertex& v : poly) {
                      const glm::dvec2 x(v.p.x, v.p.y);
                      double bw[3];
                      for (int k = 0; k < 3; ++k)
                        bw[k] = cross2(q[(k + 2) % 3] - q[(k + 1) % 3], x - q[(k + 1) % 3]) / area2;
                      DVec3 pw(0), nb(0);
                      for (int k = 0; k < 3; ++k) {
                        pw += bw[k] * (W[k] + N[k] * (v.p.z * m_wK[P.w[k]]));
                        nb += bw[k] * N[k];
                      }
                      nb = glm::normalize(nb);
                      DVec3 tx, ty;
                      frameOf(P.tri, nb, &tx, &ty);
                      DVec3 nw = v.n.x * tx + v.n.y * ty + v.n.z * nb;
                      const double l = glm::length(nw);
                      nw = l > 0 ? nw / l : nb;
                      out.pos.push_back(Vec3(pw));
                      out.nrm.push_back(Vec3(nw));
                    }
                    for (uint32_t k = 1; k + 1 < poly.size(); ++k) {
                      const glm::uvec3 tr(first, first + k, first + k + 1);
                      const DVec3 e1 = DVec3(out.pos[tr.y] - out.pos[tr.x]),
                                  e2 = DVec3(out.pos[tr.z] - out.pos[tr.x]);
                      if (!(glm::length(glm::cross(e1, e2)) > 0)) continue;
                      out.tri.push_back(tr);
                      out.mat.push_back(tile.triMaterial.empty() ? 0 : tile.triMaterial[t]);
                      out.base.push_back(P.tri);
                    }
                  }
            }
        }
      },
      cancel);
  throwIfCancelled(cancel, "render");
  ExactMesh X;
  for (ExactMesh& p : parts) {
    const uint32_t off = uint32_t(X.pos.size());
    X.pos.insert(X.pos.end(), p.pos.begin(), p.pos.end());
    X.nrm.insert(X.nrm.end(), p.nrm.begin(), p.nrm.end());
    for (const auto& t : p.tri) X.tri.push_back(t + glm::uvec3(off));
    X.mat.insert(X.mat.end(), p.mat.begin(), p.mat.end());
    X.base.insert(X.base.end(), p.base.begin(), p.base.end());

    ExactMesh().pos.swap(p.pos);
  }
  if (X.tri.empty()) throw Error("the exact object has no triangles (is the tile empty?)");
  if (X.tri.size() > maxTriangles)
    throw Error(
        format("the exact object holds %zu triangles; the memory budget allows %llu: lower "
               "--tiling or raise --memory-budget",
               X.tri.size(), (unsigned long long)maxTriangles));
  for (uint16_t m : X.mat)
    if (m >= materials.size()) throw Error("the tile names a material the scene does not have");
  const MeshTracer tracer(X.pos, X.tri);
  const double buildSeconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - tBuild).count();

  const float E = float(m_s.irradiance), Lenv = float(m_s.environment);
  const int limit = m_s.bounces > 0 ? std::min(m_s.bounces, 256) : 256;
  const Vec3 L(m_light);
  RenderImage img = renderWith(
      "exact", cancel, progress,
      [&](const DVec3& o, const DVec3& d, const RayDiff&, Rng& rng, Rgb* out, uint64_t* rays,
          SampleInfo*) {
        MeshHit h = tracer.intersect(o, d);
        ++*rays;
        if (!h.hit()) return false;
        // A camera ray that reaches the relief layer through the shell's bottom comes from
        // inside the object: what it meets (a brick's underside) is the object's underside,
        // black as in the mapped mode.
        const MeshHit sh = m_shell->intersect(o, d);
        ++*rays;
        if (sh.hit() && sh.t <= h.t) {
          const Face& f = m_faces[sh.prim];
          const int from = f.prism[glm::dot(d, f.n) > 0 ? 1 : 0];
          if (f.kind == 1 && from < 0) return true;
        }
        DVec3 dir = d, org = o;
        Rgb beta(1), sum(0);
        for (int bounce = 1;; ++bounce) {
          const glm::uvec3 tr = X.tri[h.prim];
          const Vec3 a = X.pos[tr.x], b = X.pos[tr.y], c = X.pos[tr.z];
          Vec3 ng = glm::cross(b - a, c - a);
          const float l = glm::length(ng);
          if (!(l > 0)) break;
          ng /= l;
          const float w0 = 1 - h.u - h.v;
          Vec3 n = glm::normalize(w0 * X.nrm[tr.x] + h.u * X.nrm[tr.y] + h.v * X.nrm[tr.z]);
          const Vec3 toViewer = -Vec3(dir);
          // The relief is on the object's front: the back of a micro surface (by its outward
          // vertex normals: the ground sheet or a brick's wall seen from inside an open object)
          // is the object's underside, black as in the mapped and flat modes; it absorbs paths.
          if (glm::dot(glm::dot(ng, n) >= 0 ? ng : -ng, toViewer) < 0) break;
          if (glm::dot(ng, toViewer) < 0) ng = -ng, n = -n;
          const DVec3 p = org + dir * h.t;
          const Material& mat = materials[X.mat[h.prim]];
          const Frame frame = Frame::fromNormal(n, Vec3(m_triT[X.base[h.prim]]));
          const Vec3 woL = frame.toLocal(toViewer);
          const DVec3 origin = p + DVec3(ng) * m_eps;
          const float cosN = glm::dot(n, L);
          if (E > 0 && cosN > 0 && glm::dot(ng, L) > 0) {
            ++*rays;
            if (!tracer.occluded(origin, m_light))
              sum += beta * evalBrdf(mat, frame.toLocal(L), woL) * (cosN * E);
          }
          // After the last bounce a sample is still drawn when there is a sky: it is direct
          // light too (an escaping sample adds it; a hit adds nothing more).
          if (bounce >= limit && !(Lenv > 0)) break;
          const float u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
          const BrdfSample bs = sampleBrdf(mat, woL, u0, u1, u2);
          if (!(bs.pdf > 0)) break;
          const Vec3 wiW = frame.toWorld(bs.wi);
          if (glm::dot(ng, wiW) <= 0) break;
          beta *= evalBrdf(mat, bs.wi, woL) * (bs.wi.z / bs.pdf);
          if (bounce >= 3 && bounce < limit) {
            const float qq = std::min(0.95f, std::max(beta.x, std::max(beta.y, beta.z)));
            if (!(qq > 0) || rng.uniform() >= qq) break;
            beta /= qq;
          }
          if (!(beta.x > 0 || beta.y > 0 || beta.z > 0)) break;
          dir = glm::normalize(DVec3(wiW));
          org = origin;
          h = tracer.intersect(org, dir);
          ++*rays;
          if (!h.hit()) {
            sum += beta * Lenv;  // the path escapes to the sky
            break;
          }
          if (bounce >= limit) break;
        }
        *out = sum;
        return true;
      });
  img.triangles = X.tri.size();
  img.seconds += buildSeconds;
  return img;
}

ImageError compareImages(const RenderImage& img, const RenderImage& ref) {
  if (img.width != ref.width || img.height != ref.height)
    throw Error(format("images of different sizes (%dx%d vs %dx%d)", img.width, img.height,
                       ref.width, ref.height));
  ImageError e;
  double num = 0, den = 0, numIn = 0, denIn = 0;
  for (size_t p = 0; p < img.alpha.size(); ++p) {
    const bool a = img.alpha[p] >= 0.5f, b = ref.alpha[p] >= 0.5f;
    e.refPixels += b;
    e.mismatchPixels += a != b;
    e.extraPixels += a && !b;
    if (!a && !b) continue;
    const bool interior = img.alpha[p] >= 0.999f && ref.alpha[p] >= 0.999f;
    e.interiorPixels += interior;
    for (int k = 0; k < 3; ++k) {
      const double d = double(img.rgb[p * 3 + size_t(k)]) - double(ref.rgb[p * 3 + size_t(k)]);
      const double r2 = double(ref.rgb[p * 3 + size_t(k)]) * double(ref.rgb[p * 3 + size_t(k)]);
      num += d * d, den += r2;
      if (interior) numIn += d * d, denIn += r2;
    }
  }
  auto rel = [](double n, double d) { return d > 0 ? std::sqrt(n / d) : (n > 0 ? 1.0 : 0.0); };
  e.relRmse = rel(num, den);
  e.relRmseInterior = rel(numIn, denIn);
  e.coverageMismatch = e.refPixels > 0 ? double(e.mismatchPixels) / double(e.refPixels) : 0.0;
  return e;
}

}  // namespace btf
