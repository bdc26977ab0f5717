// The BTF sampler of the renderer: a stored or compressed BTF read at a texture-space footprint
// (texel levels, filters, the visibility map and the ambient term), and the tile it came from.
#include "render_internal.h"

namespace btf {

using namespace renderdetail;


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
  t.map = r.readVmfAll();
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
    m_vmf = c.vmf();  // its own visibility map (level 0), when it carries one
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
    if (I.hasVmf) m_vmf = r.readVmfAll();
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
  // A raw store given beside a .cbtf supplies the map (in place of the file's own 8-bit one).
  if (compressed && !vmfPath.empty()) m_vmf = readVmfTable(vmfPath, I, path).map;
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
  // A decoder continuous in direction (neural) is evaluated at the pair itself at level 0;
  // coarser levels, decoded into memory, interpolate between the set's directions.
  const Decoder* cont = m_lv[0].dec && m_lv[0].dec->continuous() ? m_lv[0].dec.get() : nullptr;
  double ang[4] = {0, 0, 0, 0};
  if (cont) {
    ang[0] = std::acos(std::clamp(wi.z, -1.0, 1.0)), ang[1] = std::atan2(wi.y, wi.x);
    ang[2] = std::acos(std::clamp(wo.z, -1.0, 1.0)), ang[3] = std::atan2(wo.y, wo.x);
  }
  Rgb acc(0);
  filtered(x, y, fp, [&](int level, double px, double py, double lw) {
    bilinear(level, px, py, [&](int64_t t, double w) {
      if (cont && level == 0) {
        const auto v = cont->evaluate(t, ang[0], ang[1], ang[2], ang[3]);
        acc += float(lw * w) * Rgb(v[0], v[1], v[2]);
        return;
      }
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

}  // namespace btf
