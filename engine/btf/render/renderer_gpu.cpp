// The shell of a RenderScene flattened for the GLSL march of the studio's mapped view
// (shaders/btf_shell.glsl): vertices, faces, prisms, frames, normals and a bounding volume
// hierarchy over the faces, all in one float array (RenderScene::gpuTables, renderer.h).
#include <btf/core/error.h>
#include <btf/core/format.h>
#include <btf/render/renderer.h>

#include <algorithm>
#include <array>
#include <limits>
#include <numeric>

namespace btf {

namespace {

struct Box {
  glm::vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
  void add(const glm::vec3& p) { lo = glm::min(lo, p), hi = glm::max(hi, p); }
  void add(const Box& b) { lo = glm::min(lo, b.lo), hi = glm::max(hi, b.hi); }
};

// A bounding volume hierarchy over boxes, split at the median of the centroids along the
// widest axis, leaves of at most 4; nodes in depth-first order with skip links, so the GLSL
// walks it without a stack: a hit node goes on to the next node, a missed one (or a finished
// leaf) to its skip.
class BvhWriter {
 public:
  BvhWriter(const std::vector<Box>& boxes, std::vector<float>* nodes, std::vector<float>* leaves)
      : m_boxes(boxes), m_nodes(nodes), m_leaves(leaves) {
    m_order.resize(boxes.size());
    std::iota(m_order.begin(), m_order.end(), 0u);
    if (!boxes.empty()) build(0, m_order.size());
  }

 private:
  const std::vector<Box>& m_boxes;
  std::vector<float>* m_nodes;
  std::vector<float>* m_leaves;
  std::vector<uint32_t> m_order;

  void build(size_t b, size_t e) {
    Box box, cent;
    for (size_t k = b; k < e; ++k) {
      const Box& x = m_boxes[m_order[k]];
      box.add(x);
      cent.add(0.5f * (x.lo + x.hi));
    }
    const size_t node = m_nodes->size() / 8;
    // A hair of margin: a ray grazing a flat face's box is not lost to rounding.
    const glm::vec3 pad = 1e-6f * (box.hi - box.lo) + glm::vec3(1e-30f);
    for (int i = 0; i < 3; ++i) m_nodes->push_back(box.lo[i] - pad[i]);
    for (int i = 0; i < 3; ++i) m_nodes->push_back(box.hi[i] + pad[i]);
    m_nodes->push_back(0);   // skip, set below
    m_nodes->push_back(-1);  // inner
    if (e - b <= 4) {
      (*m_nodes)[node * 8 + 7] = float(m_leaves->size());
      m_leaves->push_back(float(e - b));
      for (size_t k = b; k < e; ++k) m_leaves->push_back(float(m_order[k]));
    } else {
      const glm::vec3 ext = cent.hi - cent.lo;
      const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : ext.y >= ext.z ? 1 : 2;
      const size_t mid = b + (e - b) / 2;
      std::nth_element(m_order.begin() + ptrdiff_t(b), m_order.begin() + ptrdiff_t(mid),
                       m_order.begin() + ptrdiff_t(e), [&](uint32_t x, uint32_t y) {
                         const Box &A = m_boxes[x], &B = m_boxes[y];
                         return A.lo[axis] + A.hi[axis] < B.lo[axis] + B.hi[axis];
                       });
      build(b, mid);
      build(mid, e);
    }
    (*m_nodes)[node * 8 + 6] = float(m_nodes->size() / 8);
  }
};

}  // namespace

ShellGpuTables RenderScene::gpuTables() const {
  ShellGpuTables g;
  const size_t limit = size_t(1) << 24;  // indices travel as floats
  if (m_sv.size() >= limit || m_faces.size() >= limit || m_prisms.size() >= limit)
    throw Error(format("object %s: its shell (%zu faces) is too large for the GPU march",
                       m_obj.name.c_str(), m_faces.size()));
  g.vertices = int(m_sv.size()), g.faces = int(m_faces.size()), g.prisms = int(m_prisms.size());
  g.welded = int(m_wnrm.size());
  g.eps = m_eps, g.hlo = m_hlo, g.hhi = m_hhi, g.Lx = m_Lx, g.Ly = m_Ly;
  std::vector<float>& d = g.data;
  g.oVertex = 0;
  for (const DVec3& v : m_sv) d.insert(d.end(), {float(v.x), float(v.y), float(v.z)});
  g.oFace = int(d.size());
  for (const Face& f : m_faces)
    d.insert(d.end(), {float(f.v[0]), float(f.v[1]), float(f.v[2]), float(f.prism[0]),
                       float(f.prism[1]), float(f.kind)});
  g.oPrism = int(d.size());
  for (const Prism& p : m_prisms) {
    for (uint32_t f : p.face) d.push_back(float(f));
    for (uint32_t w : p.w) d.push_back(float(w));
    for (int32_t n : p.nb) d.push_back(float(n));
    d.push_back(float(p.open));
    for (const glm::dvec2& x : p.xy) d.insert(d.end(), {float(x.x), float(x.y)});
  }
  g.oFrame = int(d.size());
  for (const Prism& p : m_prisms) {
    const DVec3 &t = m_triT[p.tri], &b = m_triB[p.tri];
    d.insert(d.end(), {float(t.x), float(t.y), float(t.z), float(b.x), float(b.y), float(b.z)});
  }
  g.oNormal = int(d.size());
  for (const Vec3& n : m_wnrm) d.insert(d.end(), {n.x, n.y, n.z});
  std::vector<Box> boxes(m_faces.size());
  for (size_t k = 0; k < m_faces.size(); ++k)
    for (uint32_t v : m_faces[k].v) boxes[k].add(glm::vec3(m_sv[v]));
  std::vector<float> nodes, leaves;
  BvhWriter(boxes, &nodes, &leaves);
  g.nodes = int(nodes.size() / 8);
  g.oNode = int(d.size());
  d.insert(d.end(), nodes.begin(), nodes.end());
  g.oLeaf = int(d.size());
  d.insert(d.end(), leaves.begin(), leaves.end());
  if (d.size() >= limit * 8)
    throw Error(format("object %s: its shell tables (%zu floats) are too large for the GPU",
                       m_obj.name.c_str(), d.size()));
  return g;
}

}  // namespace btf
