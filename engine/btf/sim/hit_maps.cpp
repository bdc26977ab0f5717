#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/sim/hit_maps.h>

#include <algorithm>
#include <cmath>

namespace btf {

DVec3 SampleGrid::position(int a, int b) const {
  double ja = 0.5, jb = 0.5;
  if (spp > 1) {
    const uint64_t h = hashKeys(seed, uint64_t(a), uint64_t(b), 0x5a17);
    ja = uniformFloat(h);
    jb = uniformFloat(mix64(h));
  }
  return {(a + ja) * Lx / su(), (b + jb) * Ly / sv(), 0.0};
}

RayHit traceSampleRay(const PeriodicTracer& tracer, const DVec3& p0, const DVec3& w, float* depth) {
  const TileGeometry& g = tracer.geometry();
  const double cosT = w.z;
  BTF_CHECK(cosT > 0);
  // Start just above the geometry's slab on the line through p0 along ω, travel along −ω.
  const double top = (std::max(double(g.zmax), 0.0) + 2 * tracer.epsilon()) / cosT;
  const DVec3 o = p0 + top * w;
  RayHit h = tracer.intersect(o, -w, 0.0);
  *depth = h.hit() ? float(top - h.t) : -INFINITY;
  return h;
}

void HitMaps::build(const PeriodicTracer& tracer, const DirectionSet& dirs, const SampleGrid& grid,
                    ProgressReporter* progress, const CancelToken* cancel) {
  m_grid = grid;
  m_nDirs = dirs.size();
  const size_t n = size_t(m_nDirs) * size_t(grid.samples());
  m_prim.assign(n, kNoHit);
  m_depth.assign(n, -INFINITY);
  m_u.assign(n, 0.f);
  m_v.assign(n, 0.f);
  const int su = grid.su(), sv = grid.sv();
  // One task per (direction, row of samples): rays of a row are spatially coherent.
  parallelForChunks(
      int64_t(m_nDirs) * sv, 4,
      [&](int64_t b, int64_t e) {
        for (int64_t k = b; k < e; ++k) {
          const int d = int(k / sv), row = int(k % sv);
          const DVec3 w = dirs[d].w;
          for (int a = 0; a < su; ++a) {
            const int64_t s = int64_t(row) * su + a;
            float depth;
            const RayHit h = traceSampleRay(tracer, grid.position(a, row), w, &depth);
            const size_t i = idx(d, s);
            m_prim[i] = h.prim;
            m_depth[i] = depth;
            m_u[i] = h.u;
            m_v[i] = h.v;
          }
          if (progress && row == sv - 1) progress->add(1);
        }
      },
      cancel);
}

void HitMaps::buildEdgeTables(const TileGeometry& geom, const CancelToken* cancel) {
  const int su = m_grid.su(), sv = m_grid.sv();
  const size_t stride = size_t(su + 1) * size_t(sv + 1);
  m_edgeSat.assign(size_t(m_nDirs) * stride, 0u);
  // Block maxima: level k holds blocks of 2^(k+1) × 2^(k+1) samples, up to one block per map.
  m_blockLevels.clear();
  size_t perDir = 0;
  for (int k = 0;; ++k) {
    const int w = 2 << k;
    const int nbu = (su + w - 1) / w, nbv = (sv + w - 1) / w;
    m_blockLevels.push_back({nbu, nbv, perDir});
    perDir += size_t(nbu) * nbv;
    if (nbu == 1 && nbv == 1) break;
  }
  m_blockPerDir = perDir;
  m_blockMax.assign(size_t(m_nDirs) * perDir, -INFINITY);
  const float step = 3.0f * float(std::max(m_grid.Lx / su, m_grid.Ly / sv));
  parallelForChunks(
      m_nDirs, 1,
      [&](int64_t b, int64_t e) {
        std::vector<uint8_t> mask(size_t(su) * sv);
        for (int64_t d = b; d < e; ++d) {
          std::fill(mask.begin(), mask.end(), uint8_t(0));
          const size_t base = idx(int(d), 0);
          auto key = [&](int a, int r) { return base + size_t(r) * su + size_t(a); };
          auto differ = [&](size_t x, size_t y) {
            const uint32_t px = m_prim[x], py = m_prim[y];
            if ((px == kNoHit) != (py == kNoHit)) return true;
            if (px == kNoHit) return false;
            if (geom.triMaterial[px] != geom.triMaterial[py] ||
                std::abs(m_depth[x] - m_depth[y]) > step)
              return true;
            // A crease (the top of a wall): shading normals more than ~25° apart (those of a
            // smooth tessellated curve turn far less between neighbouring samples).
            if (px == py) return false;
            const Vec3 nx = geom.shadingNormal(px, m_u[x], m_v[x]);
            const Vec3 ny = geom.shadingNormal(py, m_u[y], m_v[y]);
            const float lx = glm::length(nx), ly = glm::length(ny);
            return lx > 0 && ly > 0 && std::abs(glm::dot(nx, ny)) < 0.9f * lx * ly;
          };
          for (int r = 0; r < sv; ++r)
            for (int a = 0; a < su; ++a) {
              const size_t k = key(a, r);
              const int an = a + 1 == su ? 0 : a + 1, rn = r + 1 == sv ? 0 : r + 1;
              if (differ(k, key(an, r))) mask[size_t(r) * su + a] = mask[size_t(r) * su + an] = 1;
              if (differ(k, key(a, rn))) mask[size_t(r) * su + a] = mask[size_t(rn) * su + a] = 1;
            }
          uint32_t* sat = &m_edgeSat[size_t(d) * stride];
          for (int r = 0; r < sv; ++r) {
            uint32_t row = 0;
            for (int a = 0; a < su; ++a) {
              row += mask[size_t(r) * su + a];
              sat[size_t(r + 1) * (su + 1) + a + 1] = sat[size_t(r) * (su + 1) + a + 1] + row;
            }
          }
          float* bm = &m_blockMax[size_t(d) * m_blockPerDir];
          const BlockLevel& l0 = m_blockLevels[0];
          for (int r = 0; r < sv; ++r)
            for (int a = 0; a < su; ++a) {
              float& x = bm[l0.offset + size_t(r / 2) * l0.nu + size_t(a / 2)];
              x = std::max(x, m_depth[key(a, r)]);
            }
          for (size_t k = 1; k < m_blockLevels.size(); ++k) {
            const BlockLevel &f = m_blockLevels[k - 1], &c = m_blockLevels[k];
            for (int r = 0; r < f.nv; ++r)
              for (int a = 0; a < f.nu; ++a) {
                float& x = bm[c.offset + size_t(r / 2) * c.nu + size_t(a / 2)];
                x = std::max(x, bm[f.offset + size_t(r) * f.nu + size_t(a)]);
              }
          }
        }
      },
      cancel);
}

namespace {

// Splits the wrapped span [a0, a1) of a period-n axis into at most two spans inside [0, n).
int wrapSpans(int a0, int a1, int n, int out[2][2]) {
  if (a1 - a0 >= n) a0 = 0, a1 = n;
  const int s = a0 - ((a0 % n) + n) % n;
  a0 -= s, a1 -= s;
  int k = 0;
  if (std::min(a1, n) > a0) out[k][0] = a0, out[k][1] = std::min(a1, n), ++k;
  if (a1 > n) out[k][0] = 0, out[k][1] = a1 - n, ++k;
  return k;
}

}  // namespace

uint32_t HitMaps::edgeCount(int dir, int a0, int a1, int b0, int b1) const {
  const int su = m_grid.su(), sv = m_grid.sv();
  const uint32_t* sat = &m_edgeSat[size_t(dir) * size_t(su + 1) * size_t(sv + 1)];
  auto at = [&](int a, int b) { return sat[size_t(b) * (su + 1) + a]; };
  if (a0 >= 0 && b0 >= 0 && a1 <= su && b1 <= sv)  // inside the map: no wrap
    return a1 > a0 && b1 > b0 ? at(a1, b1) - at(a0, b1) - at(a1, b0) + at(a0, b0) : 0u;
  int as[2][2], bs[2][2];
  const int na = wrapSpans(a0, a1, su, as), nb = wrapSpans(b0, b1, sv, bs);
  uint32_t n = 0;
  for (int x = 0; x < na; ++x)
    for (int y = 0; y < nb; ++y)
      n += at(as[x][1], bs[y][1]) - at(as[x][0], bs[y][1]) - at(as[x][1], bs[y][0]) +
           at(as[x][0], bs[y][0]);
  return n;
}

float HitMaps::maxDepth(int dir, int a0, int a1, int b0, int b1) const {
  const int su = m_grid.su(), sv = m_grid.sv();
  int as[2][2], bs[2][2];
  int na = 1, nb = 1;
  if (a0 >= 0 && b0 >= 0 && a1 <= su && b1 <= sv) {  // inside the map: no wrap
    if (a1 <= a0 || b1 <= b0) return -INFINITY;
    as[0][0] = a0, as[0][1] = a1, bs[0][0] = b0, bs[0][1] = b1;
  } else {
    na = wrapSpans(a0, a1, su, as), nb = wrapSpans(b0, b1, sv, bs);
  }
  // The finest level at which the rectangle touches at most 5 blocks a side (an upper bound all
  // the same: a block's maximum covers the rectangle's part of it).
  const int span = std::max(std::min(a1 - a0, su), std::min(b1 - b0, sv));
  size_t k = 0;
  while (k + 1 < m_blockLevels.size() && span > (8 << k)) ++k;
  const BlockLevel& L = m_blockLevels[k];
  const int sh = int(k) + 1;
  const float* bm = &m_blockMax[size_t(dir) * m_blockPerDir + L.offset];
  float m = -INFINITY;
  for (int y = 0; y < nb; ++y)
    for (int r = bs[y][0] >> sh; r <= (bs[y][1] - 1) >> sh; ++r)
      for (int x = 0; x < na; ++x)
        for (int c = as[x][0] >> sh; c <= (as[x][1] - 1) >> sh; ++c)
          m = std::max(m, bm[size_t(r) * L.nu + size_t(c)]);
  return m;
}

std::vector<float> HitMaps::vmf(int dir) const {
  const int nu = m_grid.nu, nv = m_grid.nv, K = m_grid.spp;
  std::vector<float> out(size_t(nu) * nv * 2, 0.f);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      int hits = 0;
      double sum = 0;
      for (int s = 0; s < K * K; ++s) {
        const int64_t si = m_grid.sampleIndex(i, j, s);
        if (prim(dir, si) != kNoHit) {
          ++hits;
          sum += depth(dir, si);
        }
      }
      out[(size_t(j) * nu + i) * 2] = float(hits) / float(K * K);
      out[(size_t(j) * nu + i) * 2 + 1] = hits ? float(sum / hits) : 0.f;
    }
  return out;
}

}  // namespace btf
