#include <btf/core/error.h>
#include <btf/core/rng.h>
#include <btf/core/run_context.h>
#include <btf/sim/network.h>
#include <btf/sim/shading.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace btf {

namespace {
using Clock = std::chrono::steady_clock;
// Direction (a, c) of a side × side stratified cosine-weighted set around the z axis, jittered
// by the hash h.
Vec3 stratifiedCosine(int a, int c, int side, uint64_t h) {
  const float u1 = (a + uniformFloat(h)) / side, u2 = (c + uniformFloat(mix64(h))) / side;
  const float r = std::sqrt(u1), phi = 2 * kPiF * u2;
  return Vec3(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.f, 1 - u1)));
}
uint32_t floatBits(float x) {
  uint32_t b;
  std::memcpy(&b, &x, 4);
  return b;
}
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
float wrap(float x, double L) {
  float r = float(x - std::floor(double(x) / L) * L);
  return r >= float(L) ? 0.0f : r;
}
float luminance(const Rgb& c) {
  return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
}
bool isGlossy(const Material& m) {
  return m.type != BrdfType::Lambert && (m.ks.x > 0 || m.ks.y > 0 || m.ks.z > 0);
}
}  // namespace

uint64_t PointNetwork::memoryBytes() const {
  return m_points.size() * sizeof(NetworkPoint) + m_links.size() * sizeof(NetworkLink) +
         (m_cellStart.size() + m_cellPoints.size()) * 4;
}

void PointNetwork::buildGrid() {
  const size_t cells = size_t(m_nx) * m_ny * m_nz;
  m_cellStart.assign(cells + 1, 0);
  auto cellOf = [&](const Vec3& p) {
    const int cx = std::min(m_nx - 1, int(p.x / m_cx)), cy = std::min(m_ny - 1, int(p.y / m_cy));
    const int cz = std::clamp(int((p.z - m_z0) / m_cz), 0, m_nz - 1);
    return (size_t(cz) * m_ny + cy) * m_nx + cx;
  };
  for (const auto& q : m_points) ++m_cellStart[cellOf(q.p) + 1];
  for (size_t c = 0; c < cells; ++c) m_cellStart[c + 1] += m_cellStart[c];
  m_cellPoints.assign(m_points.size(), 0);
  std::vector<uint32_t> fill(m_cellStart.begin(), m_cellStart.end() - 1);
  for (uint32_t i = 0; i < m_points.size(); ++i) m_cellPoints[fill[cellOf(m_points[i].p)]++] = i;
}

template <class F>
void PointNetwork::forNeighbours(const Vec3& pin, int ring, F&& f) const {
  const Vec3 p(wrap(pin.x, m_Lx), wrap(pin.y, m_Ly), pin.z);
  const int cx = std::min(m_nx - 1, int(p.x / m_cx)), cy = std::min(m_ny - 1, int(p.y / m_cy));
  const int cz = int(std::floor((p.z - m_z0) / m_cz));
  const int rx = std::min(ring, (m_nx - 1) / 2), ry = std::min(ring, (m_ny - 1) / 2);
  // p and the points lie in [0, L): the nearest periodic image is one compare away (what
  // d − round(d / L) · L gives, without its division).
  const float Lx = float(m_Lx), Ly = float(m_Ly), hx = float(0.5 * m_Lx), hy = float(0.5 * m_Ly);
  for (int dz = -ring; dz <= ring; ++dz) {
    const int z = cz + dz;
    if (z < 0 || z >= m_nz) continue;
    for (int dy = -ry; dy <= ry; ++dy) {
      const int y = ((cy + dy) % m_ny + m_ny) % m_ny;
      for (int dx = -rx; dx <= rx; ++dx) {
        const int x = ((cx + dx) % m_nx + m_nx) % m_nx;
        const size_t c = (size_t(z) * m_ny + y) * m_nx + x;
        for (uint32_t k = m_cellStart[c]; k < m_cellStart[c + 1]; ++k) {
          const uint32_t i = m_cellPoints[k];
          Vec3 d = m_points[i].p - p;
          if (d.x > hx) d.x -= Lx;
          else if (d.x < -hx) d.x += Lx;
          if (d.y > hy) d.y -= Ly;
          else if (d.y < -hy) d.y += Ly;
          f(i, d);
        }
      }
    }
  }
}

int PointNetwork::nearest(const Vec3& p, const Vec3& n, int k, uint32_t* idx, float* w) const {
  if (m_points.empty() || k <= 0) return 0;
  const float maxD2 = 4.0f * m_h * m_h;
  int found = 0;
  float d2s[16];
  k = std::min(k, 16);
  forNeighbours(p, 2, [&](uint32_t i, const Vec3& d) {
    const float d2 = glm::dot(d, d);
    if (d2 > maxD2 || m_points[i].enclosed || glm::dot(m_points[i].ng, n) < 0.3f) return;
    if (found == k && d2 >= d2s[k - 1]) return;
    int pos = found < k ? found++ : k - 1;
    while (pos > 0 && d2s[pos - 1] > d2) {
      d2s[pos] = d2s[pos - 1];
      idx[pos] = idx[pos - 1];
      --pos;
    }
    d2s[pos] = d2;
    idx[pos] = i;
  });
  float sum = 0;
  for (int i = 0; i < found; ++i) sum += (w[i] = 1.0f / (std::sqrt(d2s[i]) + 0.5f * m_h));
  for (int i = 0; i < found; ++i) w[i] /= sum;
  return found;
}

void PointNetwork::build(const PeriodicTracer& tracer, const NetworkSettings& s,
                         ProgressReporter* progress, const CancelToken* cancel) {
  const auto start = Clock::now();
  if (s.voxels < 2 || s.voxels > 1024)
    throw Error("network density must be between 2 and 1024 voxels per side (got " +
                std::to_string(s.voxels) + ")");
  if (s.links < 1 || s.links > 256) throw Error("network links per point must be 1..256");
  if (s.alphaDirections < 16 || s.alphaDirections > 4096)
    throw Error("network visibility directions must be 16..4096");
  if (s.gather < 1 || s.gather > 16) throw Error("network gather points (N1) must be 1..16");
  if (s.gatherOcclusion < 0 || s.gatherOcclusion > 1024)
    throw Error("network gather occlusion rays must be 0..1024");
  m_settings = s;
  const TileGeometry& g = tracer.geometry();
  m_Lx = g.Lx;
  m_Ly = g.Ly;
  m_h = float(std::max(g.Lx, g.Ly) / s.voxels);
  m_nx = std::max(1, int(std::lround(g.Lx / m_h)));
  m_ny = std::max(1, int(std::lround(g.Ly / m_h)));
  m_cx = float(g.Lx / m_nx);
  m_cy = float(g.Ly / m_ny);
  m_z0 = g.zmin - 1e-4f * m_h;
  m_nz = std::max(1, int(std::ceil((g.zmax - m_z0) / m_h + 1e-4)));
  m_cz = m_h;
  const size_t voxels = size_t(m_nx) * m_ny * m_nz;
  // Six candidates of 16 bytes per voxel while sampling: at most 256 MiB.
  if (voxels * 6 > (size_t(1) << 24))
    throw Error("network voxel grid of " + std::to_string(m_nx) + "x" + std::to_string(m_ny) + "x" +
                std::to_string(m_nz) +
                " voxels is too large (at most 2.8 million): lower --network-voxels");

  // 1. Voxelise: each voxel keeps the sub-triangle centroid closest to its centre — one per
  // orientation class (the dominant axis of the normal, ±x, ±y, ±z), so that a floor and a wall
  // sharing a voxel (a mortar gap narrower than a voxel) are both represented.
  struct Cand {
    float d2 = INFINITY;
    uint32_t prim = 0;
    float u = 0, v = 0;
  };
  std::vector<Cand> best(voxels * 6);
  const float areaThreshold = 0.25f * m_h * m_h;
  struct Sub {
    Vec3 a, b, c;
    Vec2 ba, bb, bc;  // Embree barycentrics (u, v) of the corners
    int depth;
  };
  std::vector<Sub> stack;
  for (uint32_t t = 0; t < g.triangleCount(); ++t) {
    const auto& tri = g.mesh.tri[t];
    const Vec3 p0 = g.mesh.pos[tri.x], p1 = g.mesh.pos[tri.y], p2 = g.mesh.pos[tri.z];
    if (!(glm::length(glm::cross(p1 - p0, p2 - p0)) > 1e-12f * m_h * m_h)) continue;
    const Vec3 fnt = g.faceNormal(t);
    const Vec3 an = glm::abs(fnt);
    const int axis = an.x >= an.y && an.x >= an.z ? 0 : an.y >= an.z ? 1 : 2;
    const int cls = 2 * axis + (fnt[axis] < 0 ? 1 : 0);
    stack.push_back({p0, p1, p2, Vec2(0, 0), Vec2(1, 0), Vec2(0, 1), 0});
    while (!stack.empty()) {
      Sub q = stack.back();
      stack.pop_back();
      const float area = 0.5f * glm::length(glm::cross(q.b - q.a, q.c - q.a));
      if (area > areaThreshold && q.depth < 20) {
        const Vec3 ab = 0.5f * (q.a + q.b), bc = 0.5f * (q.b + q.c), ca = 0.5f * (q.c + q.a);
        const Vec2 bab = 0.5f * (q.ba + q.bb), bbc = 0.5f * (q.bb + q.bc),
                   bca = 0.5f * (q.bc + q.ba);
        const int d = q.depth + 1;
        stack.push_back({q.a, ab, ca, q.ba, bab, bca, d});
        stack.push_back({ab, q.b, bc, bab, q.bb, bbc, d});
        stack.push_back({ca, bc, q.c, bca, bbc, q.bc, d});
        stack.push_back({ab, bc, ca, bab, bbc, bca, d});
        continue;
      }
      const Vec3 c = (q.a + q.b + q.c) / 3.0f;
      const Vec2 bcen = (q.ba + q.bb + q.bc) / 3.0f;
      const Vec3 w(wrap(c.x, g.Lx), wrap(c.y, g.Ly), c.z);
      const int ix = std::min(m_nx - 1, int(w.x / m_cx)), iy = std::min(m_ny - 1, int(w.y / m_cy));
      const int iz = std::clamp(int((w.z - m_z0) / m_cz), 0, m_nz - 1);
      const Vec3 centre((ix + 0.5f) * m_cx, (iy + 0.5f) * m_cy, m_z0 + (iz + 0.5f) * m_cz);
      const Vec3 d = w - centre;
      const float d2 = glm::dot(d, d);
      Cand& b = best[((size_t(iz) * m_ny + iy) * m_nx + ix) * 6 + size_t(cls)];
      if (d2 < b.d2) b = {d2, t, bcen.x, bcen.y};
    }
  }
  // 2. Points in voxel order, normals on the triangle's side.
  std::vector<NetworkPoint> cands;
  for (const Cand& c : best) {
    if (!std::isfinite(c.d2)) continue;
    NetworkPoint q;
    q.prim = c.prim;
    const Vec3 p = g.point(c.prim, c.u, c.v);
    q.p = Vec3(wrap(p.x, g.Lx), wrap(p.y, g.Ly), p.z);
    q.ng = glm::normalize(g.faceNormal(c.prim));
    Vec3 ns = g.shadingNormal(c.prim, c.u, c.v);
    const float l = glm::length(ns);
    ns = l > 0 ? ns / l : q.ng;
    q.ns = glm::dot(ns, q.ng) < 0 ? -ns : ns;
    cands.push_back(q);
  }
  // 3. Prune points closer than the minimum distance among points of similar orientation
  // (greedy, in voxel order: deterministic).
  m_points = cands;
  buildGrid();
  const float minD2 = (s.minDistance * m_h) * (s.minDistance * m_h);
  std::vector<uint8_t> removed(cands.size(), 0);
  for (uint32_t i = 0; i < cands.size(); ++i) {
    if (removed[i]) continue;
    forNeighbours(cands[i].p, 1, [&](uint32_t j, const Vec3& d) {
      if (j > i && glm::dot(d, d) < minD2 && glm::dot(cands[i].ng, cands[j].ng) > 0.5f)
        removed[j] = 1;
    });
  }
  m_points.clear();
  for (size_t i = 0; i < cands.size(); ++i)
    if (!removed[i]) m_points.push_back(cands[i]);
  buildGrid();

  // 4. Visibility factor and links, per point (parallel, counter-based jitter).
  const int M = s.alphaDirections;
  const int side = std::max(1, int(std::lround(std::sqrt(double(M)))));
  const int dirsUsed = side * side;
  const double eps = tracer.epsilon();
  std::vector<std::vector<NetworkLink>> perPoint(m_points.size());
  struct HitRec {
    DVec3 p;
    uint32_t prim;
    float u, v;
  };
  // The point's stratified cosine-weighted rays and what they hit; returns how many met a back
  // face.
  auto traceHits = [&](int64_t i, std::vector<HitRec>& hits, std::vector<DVec3>& hitDirs) {
    const NetworkPoint& q = m_points[size_t(i)];
    const Frame fr = Frame::fromNormal(q.ng);
    const DVec3 origin = DVec3(q.p) + eps * DVec3(q.ng);
    hits.clear();
    hitDirs.clear();
    int back = 0;
    for (int a = 0; a < side; ++a)
      for (int c = 0; c < side; ++c) {
        const uint64_t h = hashKeys(s.seed ^ 0xa1fa, uint64_t(i), uint64_t(a * side + c));
        const DVec3 d = glm::normalize(DVec3(fr.toWorld(stratifiedCosine(a, c, side, h))));
        const RayHit hit = tracer.intersect(origin, d);
        if (!hit.hit()) continue;
        back += glm::dot(g.faceNormal(hit.prim), Vec3(d)) > 0;
        hits.push_back({origin + hit.t * d, hit.prim, hit.u, hit.v});
        hitDirs.push_back(d);
      }
    return back;
  };
  // 4a. One pass of rays per point: points enclosed in a solid (most of their rays meet back
  // faces: the plane under a box) are never seen — marked, and left out of every search; the
  // others get α and their links (a random subset of the hits, drawn per point: partial
  // Fisher–Yates), each with its exact hit.
  parallelForChunks(
      int64_t(m_points.size()), 16,
      [&](int64_t b, int64_t e) {
        std::vector<HitRec> hits;
        std::vector<DVec3> hitDirs;
        std::vector<int> order;
        for (int64_t i = b; i < e; ++i) {
          NetworkPoint& q = m_points[size_t(i)];
          q.enclosed = 2 * traceHits(i, hits, hitDirs) > dirsUsed;
          if (q.enclosed) {
            q.alpha = 0;
            continue;
          }
          q.alpha = float(hits.size()) / float(dirsUsed);
          const int nh = int(hits.size());
          const int want = std::min(nh, s.links);
          order.resize(size_t(nh));
          for (int k = 0; k < nh; ++k) order[size_t(k)] = k;
          for (int k = 0; k < want; ++k) {
            const uint64_t h = hashKeys(s.seed ^ 0x11ce, uint64_t(i), uint64_t(k));
            const int r = k + int(uniformFloat(h) * float(nh - k));
            std::swap(order[size_t(k)], order[size_t(std::min(r, nh - 1))]);
          }
          auto& out = perPoint[size_t(i)];
          for (int k = 0; k < want; ++k) {
            const int hi = order[size_t(k)];
            const HitRec& hr = hits[size_t(hi)];
            NetworkLink link;
            link.dir = Vec3(hitDirs[size_t(hi)]);
            link.hitP = Vec3(hr.p);
            link.hitPrim = hr.prim;
            if (!hitNormals(g, hr.prim, hr.u, hr.v, -link.dir, &link.hitNg, &link.hitNs)) continue;
            out.push_back(link);
          }
        }
      },
      cancel);
  throwIfCancelled(cancel, "network build");
  // 4b. Each link's target: the nearest network point (not enclosed: every flag is known now)
  // facing the hit and visible from the link's source.
  parallelForChunks(
      int64_t(m_points.size()), 16,
      [&](int64_t b, int64_t e) {
        for (int64_t i = b; i < e; ++i) {
          const NetworkPoint& q = m_points[size_t(i)];
          const DVec3 origin = DVec3(q.p) + eps * DVec3(q.ng);
          for (NetworkLink& link : perPoint[size_t(i)]) {
            const DVec3 hp(link.hitP);
            uint32_t idx[4];
            float w[4];
            const int nc = nearest(link.hitP, link.hitNg, 4, idx, w);
            for (int c = 0; c < nc; ++c) {
              const NetworkPoint& t = m_points[idx[c]];
              // The target's periodic image nearest to the hit.
              DVec3 img(t.p);
              img.x += std::round((hp.x - img.x) / g.Lx) * g.Lx;
              img.y += std::round((hp.y - img.y) / g.Ly) * g.Ly;
              const DVec3 seg = img + eps * DVec3(t.ng) - origin;
              const double dist = glm::length(seg);
              if (!(dist > 4 * eps)) continue;
              const DVec3 dir = seg / dist;
              if (glm::dot(Vec3(dir), q.ng) <= 0 || glm::dot(Vec3(dir), t.ng) >= 0) continue;
              if (tracer.occluded(origin, dir, 0, dist - 2 * eps)) continue;
              link.target = idx[c];
              break;
            }
          }
          if (progress) progress->add(1);
        }
      },
      cancel);
  throwIfCancelled(cancel, "network build");
  m_links.clear();
  double sumA = 0;
  m_maxAlpha = 0;
  for (size_t i = 0; i < m_points.size(); ++i) {
    m_points[i].linkBegin = uint32_t(m_links.size());
    m_links.insert(m_links.end(), perPoint[i].begin(), perPoint[i].end());
    m_points[i].linkEnd = uint32_t(m_links.size());
    if (m_points[i].linkEnd == m_points[i].linkBegin) m_points[i].alpha = 0;  // nothing to gather
    sumA += m_points[i].alpha;
    m_maxAlpha = std::max(m_maxAlpha, double(m_points[i].alpha));
  }
  m_meanAlpha = m_points.empty() ? 0 : sumA / double(m_points.size());
  m_seconds = since(start);
}

void NetworkLighting::solve(const PointNetwork& net, const TileGeometry& geom,
                            const std::vector<Material>& materials, const DirectionSet& dirs,
                            const LightVisibility& visibility, int bounces, GlossyGather glossy,
                            ProgressReporter* progress, const CancelToken* cancel, int lightLimit,
                            int part, int parts) {
  if (parts < 1 || part < 0 || part >= parts)
    throw Error("network light: part " + std::to_string(part) + " of " + std::to_string(parts));
  const auto start = Clock::now();
  const auto& pts = net.points();
  const auto& links = net.links();
  const size_t nP = pts.size(), nLk = links.size();
  m_nL = dirs.size();
  m_E.assign(nP * size_t(m_nL) * 3, 0.0f);
  m_D.clear();
  m_Lin.clear();
  m_glossy = glossy;
  const bool directional = glossy == GlossyGather::MeanDirection;
  const bool perLink = glossy == GlossyGather::Links;
  if (directional) m_D.assign(nP * size_t(m_nL) * 3, 0.0f);
  if (perLink) m_Lin.assign(nLk * size_t(m_nL) * 3, 0.0f);
  const int P = bounces;

  // Light-independent tables: per point its material, frame and gather weight α·π/N; per link
  // into a glossy target j, the glossy BRDF of j between each of j's incoming links and the
  // direction back along the link.
  std::vector<const Material*> mat(nP);
  std::vector<Frame> frame(nP);
  std::vector<float> gw(nP, 0.0f);
  for (size_t k = 0; k < nP; ++k) {
    mat[k] = &materials[geom.triMaterial[pts[k].prim]];
    frame[k] = Frame::fromNormal(pts[k].ns);
    const uint32_t n = pts[k].linkEnd - pts[k].linkBegin;
    gw[k] = n ? pts[k].alpha * kPiF / float(n) : 0.0f;
  }
  std::vector<uint32_t> transferStart(nLk + 1, 0);
  for (size_t e = 0; e < nLk; ++e) {
    const uint32_t t = links[e].target;
    transferStart[e + 1] =
        transferStart[e] +
        (t != kNoTarget && isGlossy(*mat[t]) ? pts[t].linkEnd - pts[t].linkBegin : 0);
  }
  // Materials and frames at the exact hits (first order).
  std::vector<const Material*> hitMat(nLk);
  std::vector<Frame> hitFrame(nLk);
  for (size_t e = 0; e < nLk; ++e) {
    hitMat[e] = &materials[geom.triMaterial[links[e].hitPrim]];
    hitFrame[e] = Frame::fromNormal(links[e].hitNs);
  }
  std::vector<Rgb> transfer(transferStart[nLk]);
  parallelForChunks(int64_t(nLk), 256, [&](int64_t b, int64_t e) {
    for (int64_t x = b; x < e; ++x) {
      if (transferStart[x + 1] == transferStart[x]) continue;
      const uint32_t jt = links[size_t(x)].target;
      const NetworkPoint& j = pts[jt];
      const Vec3 out = frame[jt].toLocal(-links[size_t(x)].dir);
      for (uint32_t q = j.linkBegin; q < j.linkEnd; ++q)
        transfer[transferStart[x] + (q - j.linkBegin)] =
            evalGlossy(*mat[jt], frame[jt].toLocal(links[q].dir), out);
    }
  });

  m_setupSeconds = since(start);
  const bool tail = m_closedFormTail && P >= 3;
  const int nSolved = lightLimit > 0 ? std::min(lightLimit, m_nL) : m_nL;
  const std::vector<int> mine = lightsOfPart(nSolved, part, parts);
  m_solvedLights = int(mine.size());
  m_parts = parts;
  parallelForChunks(
      int64_t(mine.size()), 1,
      [&](int64_t mb, int64_t me) {
        std::vector<float> ehit(nLk);
        std::vector<Rgb> lin(nLk), linPrev(nLk), eOrder(nP), eTot(nP), linTot(perLink ? nLk : 0);
        std::vector<Vec3> dsum(directional ? nP : 0);
        for (int64_t m = mb; m < me; ++m) {
          const int64_t l = mine[size_t(m)];
          const Vec3 w(dirs[int(l)].w);
          const float invCos = 1.0f / float(std::max(dirs[int(l)].w.z, 1e-7));
          for (size_t e = 0; e < nLk; ++e) {
            const NetworkLink& lk = links[e];
            const float c = glm::dot(lk.hitNs, w);
            ehit[e] = 0;
            if (c > 0 && glm::dot(lk.hitNg, w) > 0)
              ehit[e] = c * visibility(int(l), lk.hitP, lk.hitNg, lk.hitPrim);
          }
          std::fill(eTot.begin(), eTot.end(), Rgb(0));
          std::fill(linTot.begin(), linTot.end(), Rgb(0));
          if (directional) std::fill(dsum.begin(), dsum.end(), Vec3(0));
          DVec3 orderSum(0), prevSum(0);  // Σ over points of the last two orders, per channel
          for (int order = 1; order < P; ++order) {
            // Radiance arriving along each link: what its target sends back toward the source.
            for (size_t e = 0; e < nLk; ++e) {
              const uint32_t j = links[e].target;
              Rgb L(0);
              if (order == 1) {
                if (ehit[e] > 0) {
                  const Material& hm = *hitMat[e];
                  L = hm.kdOverPi * ehit[e];
                  if (isGlossy(hm))
                    L +=
                        evalGlossy(hm, hitFrame[e].toLocal(w), hitFrame[e].toLocal(-links[e].dir)) *
                        ehit[e];
                }
              } else if (j != kNoTarget) {
                const Material& m = *mat[j];
                L = m.kdOverPi * eOrder[j];
                const uint32_t t0 = transferStart[e], t1 = transferStart[e + 1];
                if (t1 > t0) {
                  Rgb g(0);
                  for (uint32_t q = t0; q < t1; ++q)
                    g += transfer[q] * linPrev[pts[j].linkBegin + (q - t0)];
                  L += g * gw[j];
                }
              }
              lin[e] = L;
              if (perLink) linTot[e] += L;
            }
            for (size_t k = 0; k < nP; ++k) {
              Rgb sum(0);
              for (uint32_t e = pts[k].linkBegin; e < pts[k].linkEnd; ++e) {
                sum += lin[e];
                if (directional) dsum[k] += luminance(lin[e]) * links[e].dir;
              }
              eOrder[k] = sum * gw[k];
              eTot[k] += eOrder[k];
            }
            std::swap(lin, linPrev);
            if (tail) {
              prevSum = orderSum;
              orderSum = DVec3(0);
              for (size_t k = 0; k < nP; ++k) orderSum += DVec3(eOrder[k]);
            }
          }
          if (tail) {
            // The orders past P − 1 as a geometric series of the measured ratio: the last order
            // (eOrder at the points, linPrev along the links) times r / (1 − r).
            Rgb f(0);
            for (int c = 0; c < 3; ++c) {
              const double r =
                  prevSum[c] > 0 ? std::clamp(orderSum[c] / prevSum[c], 0.0, 0.95) : 0.0;
              f[c] = float(r / (1 - r));
            }
            for (size_t k = 0; k < nP; ++k) eTot[k] += eOrder[k] * f;
            if (perLink)
              for (size_t e = 0; e < nLk; ++e) linTot[e] += linPrev[e] * f;
          }
          if (perLink)
            for (size_t e = 0; e < nLk; ++e) {
              float* R = &m_Lin[(e * size_t(m_nL) + size_t(l)) * 3];
              for (int c = 0; c < 3; ++c)
                R[c] = std::isfinite(linTot[e][c]) ? linTot[e][c] * invCos : 0;
            }
          for (size_t k = 0; k < nP; ++k) {
            float* E = &m_E[(k * size_t(m_nL) + size_t(l)) * 3];
            for (int c = 0; c < 3; ++c) E[c] = std::isfinite(eTot[k][c]) ? eTot[k][c] * invCos : 0;
            if (directional) {
              const float len = glm::length(dsum[k]);
              const Vec3 d = len > 0 ? dsum[k] / len : pts[k].ns;
              float* D = &m_D[(k * size_t(m_nL) + size_t(l)) * 3];
              D[0] = d.x;
              D[1] = d.y;
              D[2] = d.z;
            }
          }
          if (progress) progress->add(1);
        }
      },
      cancel);
  throwIfCancelled(cancel, "network light");
  m_seconds = since(start);
}

std::vector<int> NetworkLighting::lightsOfPart(int lights, int part, int parts) {
  std::vector<int> v;
  for (int l = part; l < lights; l += parts) v.push_back(l);
  return v;
}

uint64_t NetworkLighting::share(Comm& comm, uint64_t roundBytes) {
  const int R = comm.size();
  if (R == 1) return 0;
  if (m_parts != R)
    throw Error("network light: solved in " + std::to_string(m_parts) + " parts, shared over " +
                std::to_string(R) + " ranks");
  const uint64_t before = comm.bytesSent() + comm.bytesReceived();
  const size_t nP = m_E.size() / (size_t(m_nL) * 3), nLk = m_Lin.size() / (size_t(m_nL) * 3);
  // One light's floats: its E (and D) of every point, its link radiance of every link.
  const uint64_t perLight = (uint64_t(nP) * (m_D.empty() ? 3 : 6) + uint64_t(nLk) * 3) * 4;
  const int B = int(std::clamp<uint64_t>(roundBytes / std::max<uint64_t>(perLight, 1), 1, 1 << 20));
  const int most = (m_nL + R - 1) / R;  // lights of rank 0, the most any rank has
  auto each = [&](int l, auto&& f) {  // f(pointer, floats) over the light's rows
    for (size_t k = 0; k < nP; ++k) {
      f(&m_E[(k * size_t(m_nL) + size_t(l)) * 3], 3);
      if (!m_D.empty()) f(&m_D[(k * size_t(m_nL) + size_t(l)) * 3], 3);
    }
    for (size_t e = 0; e < nLk; ++e) f(&m_Lin[(e * size_t(m_nL) + size_t(l)) * 3], 3);
  };
  for (int j0 = 0; j0 < most; j0 += B) {
    // This round: the j-th lights of every rank for j in [j0, j0 + B).
    std::string mine;
    const int j1 = std::min(most, j0 + B);
    for (int j = j0; j < j1; ++j) {
      const int l = comm.rank() + j * R;
      if (l >= m_nL) break;
      each(l, [&](const float* p, int n) {
        mine.append(reinterpret_cast<const char*>(p), size_t(n) * sizeof(float));
      });
    }
    const std::vector<std::string> all = comm.allgather(mine);
    for (int r = 0; r < R; ++r) {
      if (r == comm.rank()) continue;
      const std::string& got = all[size_t(r)];
      size_t at = 0;
      for (int j = j0; j < j1; ++j) {
        const int l = r + j * R;
        if (l >= m_nL) break;
        each(l, [&](float* p, int n) {
          const size_t bytes = size_t(n) * sizeof(float);
          if (at + bytes > got.size())
            throw Error("network light: rank " + std::to_string(r) + " sent " +
                        std::to_string(got.size()) + " bytes, fewer than its lights' rows");
          std::memcpy(p, got.data() + at, bytes);
          at += bytes;
        });
      }
      if (at != got.size())
        throw Error("network light: rank " + std::to_string(r) + " sent " +
                    std::to_string(got.size()) + " bytes for rows of " + std::to_string(at));
    }
  }
  m_parts = 1;
  return comm.bytesSent() + comm.bytesReceived() - before;
}

void NetworkGather::add(const Vec3& p, const Vec3& ng, const Vec3& ns, uint32_t prim,
                        const Vec3& wo, float weight, float* out, float alpha) const {
  uint32_t idx[16];
  float w[16];
  float ax = -1;
  const int n = neighbours(p, ng, idx, w, &ax, alpha);
  if (n == 0) return;
  const Material& m = m_materials[m_geom.triMaterial[prim]];
  const int nL = m_light.lights();
  const Rgb kd = m.kdOverPi * weight;
  for (int i = 0; i < n; ++i) {
    const float* E = m_light.irradiance(idx[i]);
    const float a = kd.x * w[i], b = kd.y * w[i], c = kd.z * w[i];
    for (int l = 0; l < nL; ++l) {
      out[3 * l] += a * E[3 * l];
      out[3 * l + 1] += b * E[3 * l + 1];
      out[3 * l + 2] += c * E[3 * l + 2];
    }
  }
  if (!isGlossy(m)) return;
  const Frame fr = Frame::fromNormal(ns);
  const Vec3 woL = fr.toLocal(wo);
  if (m_light.glossy() == GlossyGather::Links) {
    // Exactly along the links of the nearest network point: f(ω_link, ωo) · α π / N · L_link.
    const NetworkPoint& q = m_net.points()[idx[0]];
    const uint32_t nLinks = q.linkEnd - q.linkBegin;
    if (nLinks == 0) return;
    const float g = (ax >= 0 ? ax : q.alpha) * kPiF / float(nLinks) * weight;
    for (uint32_t e = q.linkBegin; e < q.linkEnd; ++e) {
      const Rgb f = evalGlossy(m, fr.toLocal(m_net.links()[e].dir), woL) * g;
      if (!(f.x > 0 || f.y > 0 || f.z > 0)) continue;
      const float* R = m_light.linkRadiance(e);
      for (int l = 0; l < nL; ++l) {
        out[3 * l] += f.x * R[3 * l];
        out[3 * l + 1] += f.y * R[3 * l + 1];
        out[3 * l + 2] += f.z * R[3 * l + 2];
      }
    }
    return;
  }
  if (!m_light.directional()) return;
  for (int l = 0; l < nL; ++l) {
    const Rgb g = meanDirectionGlossy(m, fr, woL, idx, w, n, l, weight);
    out[3 * l] += g.x;
    out[3 * l + 1] += g.y;
    out[3 * l + 2] += g.z;
  }
}

Rgb NetworkGather::meanDirectionGlossy(const Material& m, const Frame& fr, const Vec3& woL,
                                       const uint32_t* idx, const float* w, int n, int l,
                                       float weight) const {
  Vec3 d(0);
  Rgb E(0);
  for (int i = 0; i < n; ++i) {
    const float* Ei = m_light.irradiance(idx[i]) + 3 * l;
    const float* Di = m_light.direction(idx[i]) + 3 * l;
    E += w[i] * Rgb(Ei[0], Ei[1], Ei[2]);
    d += w[i] * Vec3(Di[0], Di[1], Di[2]);
  }
  if (!(E.x > 0 || E.y > 0 || E.z > 0)) return Rgb(0);
  const float len = glm::length(d);
  if (!(len > 0)) return Rgb(0);
  const Rgb f = evalGlossy(m, fr.toLocal(d / len), woL) * weight;
  return Rgb(f.x * E.x, f.y * E.y, f.z * E.z);
}

int NetworkGather::neighbours(const Vec3& p, const Vec3& ng, uint32_t* idx, float* w,
                              float* ax, float known) const {
  const int n = m_net.nearest(p, ng, m_net.settings().gather, idx, w);
  *ax = -1;
  if (n == 0 || m_alphaRays <= 0) return n;
  // E ≈ π α L̄: the hit's own occluded fraction, the occluders' mean radiance from the points.
  *ax = known >= 0 ? known : occlusion(p, ng);
  for (int i = 0; i < n; ++i) {
    const float aq = m_net.points()[idx[i]].alpha;
    w[i] *= aq > 1e-3f ? std::min(*ax / aq, 4.0f) : 1.0f;
  }
  return n;
}

void NetworkGather::Weights::reset(size_t points, size_t links, int lights) {
  point.assign(points * 3, 0.0);
  link.assign(links * 3, 0.0);
  rest.assign(size_t(lights) * 3, 0.0);
  touchedPoints.clear();
  touchedLinks.clear();
}

void NetworkGather::addWeights(const Vec3& p, const Vec3& ng, const Vec3& ns, uint32_t prim,
                               const Vec3& wo, float weight, Weights& acc,
                               float* alphaOut) const {
  // The same terms as add(), in the same order, kept per point and link.
  uint32_t idx[16];
  float w[16];
  float ax = -1;
  const int n = neighbours(p, ng, idx, w, &ax, -1);
  if (alphaOut) *alphaOut = ax;
  if (n == 0) return;
  const Material& m = m_materials[m_geom.triMaterial[prim]];
  const Rgb kd = m.kdOverPi * weight;
  for (int i = 0; i < n; ++i) {
    const Rgb k = kd * w[i];  // ≥ 0: a weight that stays 0 is never listed
    if (!(k.x > 0 || k.y > 0 || k.z > 0)) continue;
    double* c = &acc.point[size_t(idx[i]) * 3];
    if (c[0] == 0 && c[1] == 0 && c[2] == 0) acc.touchedPoints.push_back(idx[i]);
    c[0] += double(k.x), c[1] += double(k.y), c[2] += double(k.z);
  }
  if (!isGlossy(m)) return;
  const Frame fr = Frame::fromNormal(ns);
  const Vec3 woL = fr.toLocal(wo);
  if (m_light.glossy() == GlossyGather::Links) {
    const NetworkPoint& q = m_net.points()[idx[0]];
    const uint32_t nLinks = q.linkEnd - q.linkBegin;
    if (nLinks == 0) return;
    const float g = (ax >= 0 ? ax : q.alpha) * kPiF / float(nLinks) * weight;
    for (uint32_t e = q.linkBegin; e < q.linkEnd; ++e) {
      const Rgb f = evalGlossy(m, fr.toLocal(m_net.links()[e].dir), woL) * g;
      if (!(f.x > 0 || f.y > 0 || f.z > 0)) continue;
      double* c = &acc.link[size_t(e) * 3];
      if (c[0] == 0 && c[1] == 0 && c[2] == 0) acc.touchedLinks.push_back(e);
      c[0] += double(f.x), c[1] += double(f.y), c[2] += double(f.z);
    }
    return;
  }
  if (!m_light.directional()) return;
  // The mean-direction lobe depends on each light's mean direction: summed here, per light.
  for (int l = 0; l < m_light.lights(); ++l) {
    const Rgb g = meanDirectionGlossy(m, fr, woL, idx, w, n, l, weight);
    for (int c = 0; c < 3; ++c) acc.rest[size_t(3 * l + c)] += double(g[c]);
  }
}

void NetworkGather::sumWeights(const Weights& acc, double* out) const {
  const int nL = m_light.lights();
  for (int k = 0; k < 3 * nL; ++k) out[k] = acc.rest[size_t(k)];
  for (uint32_t i : acc.touchedPoints) {
    const double* c = &acc.point[size_t(i) * 3];
    const float* E = m_light.irradiance(i);
    for (int l = 0; l < nL; ++l) {
      out[3 * l] += c[0] * E[3 * l];
      out[3 * l + 1] += c[1] * E[3 * l + 1];
      out[3 * l + 2] += c[2] * E[3 * l + 2];
    }
  }
  for (uint32_t e : acc.touchedLinks) {
    const double* c = &acc.link[size_t(e) * 3];
    const float* R = m_light.linkRadiance(e);
    for (int l = 0; l < nL; ++l) {
      out[3 * l] += c[0] * R[3 * l];
      out[3 * l + 1] += c[1] * R[3 * l + 1];
      out[3 * l + 2] += c[2] * R[3 * l + 2];
    }
  }
}

void NetworkGather::addScaled(int view, const float* g, float* out) const {
  const int n = 3 * m_light.lights();
  if (m_scale.empty()) {
    for (int k = 0; k < n; ++k) out[k] += g[k];
    return;
  }
  BTF_CHECK(view >= 0 && size_t(view + 1) * size_t(n) <= m_scale.size());
  const float* s = &m_scale[size_t(view) * size_t(n)];
  for (int k = 0; k < n; ++k) out[k] += s[k] * g[k];
}

int NetworkGather::occlusionRays() const {
  if (m_alphaRays <= 0) return 0;
  const int side = std::max(1, int(std::lround(std::sqrt(double(m_alphaRays)))));
  return side * side;
}

float NetworkGather::occlusion(const Vec3& p, const Vec3& ng) const {
  BTF_CHECK(m_tracer && m_alphaRays > 0);
  const Frame fr = Frame::fromNormal(ng);
  const DVec3 origin = DVec3(p) + m_tracer->epsilon() * DVec3(ng);
  const int side = std::max(1, int(std::lround(std::sqrt(double(m_alphaRays)))));
  // Seeded by the hit's position: the same rays for any thread, chunk or rank.
  const uint64_t kx = uint64_t(floatBits(p.x)) ^ 0x0cc1,
                 kyz = (uint64_t(floatBits(p.y)) << 32) | floatBits(p.z);
  int hits = 0;
  for (int a = 0; a < side; ++a)
    for (int c = 0; c < side; ++c) {
      const uint64_t h = hashKeys(kx, kyz, uint64_t(a * side + c));
      hits += m_tracer->occluded(
          origin, glm::normalize(DVec3(fr.toWorld(stratifiedCosine(a, c, side, h)))));
    }
  return float(hits) / float(side * side);
}

const char* glossyGatherName(GlossyGather g) {
  return g == GlossyGather::None ? "none" : g == GlossyGather::Links ? "links" : "mean_direction";
}

}  // namespace btf
