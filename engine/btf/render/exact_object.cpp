// The exact mode: the scene's micro-geometry mapped through the prisms onto the object as real
// triangles, clipped at the base triangles' edges, and path traced — the reference image.
#include "render_internal.h"

namespace btf {

using namespace renderdetail;

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

}  // namespace btf
