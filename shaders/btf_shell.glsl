// The mapped mode's shell march on the GPU (thesis §4.3; the CPU original is RenderScene::march,
// segmentHit, lightAt and onObject in engine/btf/render/renderer.cpp, followed step by step):
// a camera ray enters the shell of prisms extruded along the interpolated normals, is followed
// face to face through it in object and texture space at once, and on each prism's segment the
// visibility map of the segment's texture-space direction, read where the segment's line crosses
// the reference plane, says whether the relief is hit. The light direction is found by tracing
// from the hit toward the light through the shell. Included after btf_decode.glsl.
//
// u_shell holds RenderScene::gpuTables() (renderer.h: the sections and their layouts); u_vmf the
// raw store's visibility map (VmfTable: per direction, texels × (coverage, height)), then each
// direction's z at u_oDirZ.
uniform samplerBuffer u_shell;
uniform samplerBuffer u_vmf;
uniform int u_oVertex, u_oFace, u_oPrism, u_oFrame, u_oNormal, u_oNode, u_oLeaf, u_nNodes;
uniform int u_hasVmf, u_oDirZ;
uniform float u_Lx, u_Ly, u_hlo, u_hhi;
uniform float u_eps;    // world: a step past a crossed face
uniform vec3 u_light;   // toward the light (world, unit)

#define MAX_MARCH 1024
const float kEdge = 1e-5;  // a hair of overlap on the edges of a face: no leak between triangles

float sv(int i) { return texelFetch(u_shell, i).r; }
int si(int i) { return int(floor(texelFetch(u_shell, i).r + 0.5)); }
vec3 shellVertex(int v) {
  int o = u_oVertex + 3 * v;
  return vec3(sv(o), sv(o + 1), sv(o + 2));
}

struct FaceHit {
  int f;
  float t, u, v;
};

// Möller–Trumbore against face f, keeping the nearest hit past tmin in h.
void faceHit(int f, vec3 o, vec3 d, float tmin, inout FaceHit h) {
  int b = u_oFace + 6 * f;
  vec3 v0 = shellVertex(si(b));
  vec3 e1 = shellVertex(si(b + 1)) - v0, e2 = shellVertex(si(b + 2)) - v0;
  vec3 pv = cross(d, e2);
  float det = dot(e1, pv);
  if (det == 0.0) return;
  float inv = 1.0 / det;
  vec3 tv = o - v0;
  float u = dot(tv, pv) * inv;
  if (u < -kEdge || u > 1.0 + kEdge) return;
  vec3 qv = cross(tv, e1);
  float v = dot(d, qv) * inv;
  if (v < -kEdge || u + v > 1.0 + kEdge) return;
  float t = dot(e2, qv) * inv;
  if (t > tmin && t < h.t) {
    h.f = f;
    h.t = t;
    h.u = clamp(u, 0.0, 1.0);
    h.v = clamp(v, 0.0, 1.0 - h.u);
  }
}

// The nearest of the prism's 8 faces past tmin, other than `skip` (the face just crossed).
bool nextFace(int prism, vec3 o, vec3 d, float tmin, int skip, out FaceHit h) {
  h.f = -1;
  h.t = 1e30;
  for (int k = 0; k < 8; ++k) {
    int f = si(u_oPrism + 21 * prism + k);
    if (f != skip) faceHit(f, o, d, tmin, h);
  }
  return h.f >= 0;
}

// The nearest shell face past tmin (other than `skip`): the bounding volume hierarchy walked
// without a stack through its skip links.
bool shellIntersect(vec3 o, vec3 d, float tmin, int skip, out FaceHit h) {
  h.f = -1;
  h.t = 1e30;
  vec3 inv = vec3(1.0) / vec3(abs(d.x) > 1e-30 ? d.x : 1e-30, abs(d.y) > 1e-30 ? d.y : 1e-30,
                          abs(d.z) > 1e-30 ? d.z : 1e-30);
  int i = 0;
  for (int guard = 0; guard < 65536 && i < u_nNodes; ++guard) {
    int b = u_oNode + 8 * i;
    vec3 lo = vec3(sv(b), sv(b + 1), sv(b + 2)), hi = vec3(sv(b + 3), sv(b + 4), sv(b + 5));
    vec3 t0 = (lo - o) * inv, t1 = (hi - o) * inv;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    float enter = max(max(tn.x, tn.y), max(tn.z, tmin));
    float leave = min(min(tf.x, tf.y), min(tf.z, h.t));
    int next = si(b + 6);
    if (enter <= leave) {
      int leaf = si(b + 7);
      if (leaf < 0) {
        next = i + 1;
      } else {
        int n = si(u_oLeaf + leaf);
        for (int k = 0; k < n; ++k) {
          int f = si(u_oLeaf + leaf + 1 + k);
          if (f != skip) faceHit(f, o, d, tmin, h);
        }
      }
    }
    i = next;
  }
  return h.f >= 0;
}

vec2 prismXY(int p, int i) {
  int o = u_oPrism + 21 * p + 15 + 2 * i;
  return vec2(sv(o), sv(o + 1));
}
int prismW(int p, int i) { return si(u_oPrism + 21 * p + 8 + i); }
float cross2(vec2 a, vec2 b) { return a.x * b.y - a.y * b.x; }

// Tile coordinates (x, y, h) of barycentrics (bu, bv) on face f, in prism p's coordinates.
vec3 tileCoords(int f, int p, float bu, float bv) {
  float w[3] = float[3](1.0 - bu - bv, bu, bv);
  vec3 r = vec3(0.0);
  for (int k = 0; k < 3; ++k) {
    int v = si(u_oFace + 6 * f + k);
    int wv = v / 2;
    float h = (v - 2 * wv) == 1 ? u_hhi : u_hlo;
    int i = 0;
    while (i < 2 && prismW(p, i) != wv) ++i;
    vec2 xy = prismXY(p, i);
    r += w[k] * vec3(xy, h);
  }
  return r;
}

// A world direction in the orthonormal frame of prism p at tile point t (the interpolated
// normal, the tile's x axis projected), unit.
vec3 tileDir(int p, vec3 t, vec3 d) {
  vec2 x0 = prismXY(p, 0);
  vec2 e1 = prismXY(p, 1) - x0, e2 = prismXY(p, 2) - x0;
  float det = cross2(e1, e2);
  float b1 = cross2(t.xy - x0, e2) / det, b2 = cross2(e1, t.xy - x0) / det;
  vec3 n = vec3(0.0);
  for (int i = 0; i < 3; ++i) {
    int o = u_oNormal + 3 * prismW(p, i);
    float w = i == 0 ? 1.0 - b1 - b2 : (i == 1 ? b1 : b2);
    n += w * vec3(sv(o), sv(o + 1), sv(o + 2));
  }
  float l = length(n);
  if (l > 0.0) {
    n /= l;
  } else {
    int o = u_oNormal + 3 * prismW(p, 0);
    n = vec3(sv(o), sv(o + 1), sv(o + 2));
  }
  int fo = u_oFrame + 6 * p;
  vec3 T = vec3(sv(fo), sv(fo + 1), sv(fo + 2)), B = vec3(sv(fo + 3), sv(fo + 4), sv(fo + 5));
  vec3 tx = T - n * dot(n, T);
  float lt = length(tx);
  if (!(lt > 1e-12)) {
    tx = abs(n.x) < 0.9 ? vec3(1, 0, 0) : vec3(0, 1, 0);
    tx -= n * dot(n, tx);
    lt = length(tx);
  }
  tx /= lt;
  vec3 ty = cross(n, tx);
  if (dot(ty, B) < 0.0) ty = -ty;  // a mirrored texture map
  vec3 v = vec3(dot(d, tx), dot(d, ty), dot(d, n));
  float lv = length(v);
  return lv > 0.0 ? v / lv : vec3(0, 0, 1);
}

// True when tile point x, in prism p's coordinates, lies on the object (walking across edges
// toward it, translating at seams; false past an open edge).
bool onObject(int p, vec2 x) {
  for (int step = 0; step < 16; ++step) {
    vec2 P0 = prismXY(p, 0), P1 = prismXY(p, 1), P2 = prismXY(p, 2);
    vec2 P[3] = vec2[3](P0, P1, P2);
    float det = cross2(P1 - P0, P2 - P0);
    int worstEdge = -1;
    float worst = -1e-6;
    for (int k = 0; k < 3; ++k) {
      float b = cross2(P[(k + 2) % 3] - P[(k + 1) % 3], x - P[(k + 1) % 3]) / det;
      if (b < worst) {
        worst = b;
        worstEdge = (k + 1) % 3;
      }
    }
    if (worstEdge < 0) return true;
    int open = si(u_oPrism + 21 * p + 14);
    if (((open >> worstEdge) & 1) == 1) return false;
    int q = si(u_oPrism + 21 * p + 11 + worstEdge);
    if (q < 0) return false;
    int shared = prismW(p, worstEdge);
    int iq = 0;
    while (iq < 2 && prismW(q, iq) != shared) ++iq;
    x += prismXY(q, iq) - P[worstEdge];
    p = q;
  }
  return true;
}

// The visibility map at tile point (x, y) (nearest texel, periodic) for tile direction w
// (interpolated on the set): coverage and the height of the hit above the reference plane.
void vmfAt(float x, float y, vec3 w, out float cov, out float zh) {
  cov = 1.0;
  zh = 0.0;
  if (u_hasVmf == 0) return;  // a flat tile: the reference plane itself
  float fx = floor(x / u_Lx * float(u_nu)), fy = floor(y / u_Ly * float(u_nv));
  int tx = int(fx - floor(fx / float(u_nu)) * float(u_nu));
  int ty = int(fy - floor(fy / float(u_nv)) * float(u_nv));
  int t = min(tx, u_nu - 1) + u_nu * min(ty, u_nv - 1);
  int texels = u_nu * u_nv;
  int idx[4];
  float wt[4];
  float theta = acos(clamp(w.z, -1.0, 1.0)), phi = atan(w.y, w.x);
  if (phi < 0.0) phi += kTwoPi;
  interpolateDirs(theta, phi, idx, wt);
  float c = 0.0, hs = 0.0;
  for (int k = 0; k < 4; ++k) {
    if (wt[k] <= 0.0) continue;
    int o = (idx[k] * texels + t) * 2;
    float ck = clamp(texelFetch(u_vmf, o).r, 0.0, 1.0);
    c += wt[k] * ck;
    hs += wt[k] * ck * texelFetch(u_vmf, o + 1).r * texelFetch(u_vmf, u_oDirZ + idx[k]).r;
  }
  cov = c;
  zh = c > 0.0 ? hs / c : 0.0;
}

// A uniform number in [0, 1) from a 32-bit state (PCG hash), for fractional coverage.
float uniform01(inout uint s) {
  s = s * 747796405u + 2891336453u;
  uint w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
  w = (w >> 22u) ^ w;
  return float(w >> 8u) / 16777216.0;
}

struct MarchHit {
  vec3 world, tile, crossing, wo;
  int prism;
};

bool segmentHit(int prism, vec3 tin, vec3 tout, vec3 pin, vec3 pout, vec3 d, inout uint rng,
                inout bool ahead, inout MarchHit hit) {
  vec3 w = tileDir(prism, 0.5 * (tin + tout), -d);
  if (!(w.z > 1e-7)) return false;  // rising or level in tile space: the VMF has no answer
  vec3 c = tin - (tin.z / w.z) * w;  // the line's crossing of the reference plane
  float cov, zh;
  vmfAt(c.x, c.y, w, cov, zh);
  if (!(cov > 0.0)) return false;
  float lo = min(tin.z, tout.z), hi = max(tin.z, tout.z);
  float tol = 1e-5 * (u_hhi - u_hlo);
  if (zh < lo - tol) {
    ahead = true;  // a later prism's
    return false;
  }
  if (zh > hi + tol && !ahead) return false;  // passed over it
  if (cov < 1.0 && uniform01(rng) >= cov) return false;
  vec3 at = c + (zh / w.z) * w;
  if (!onObject(prism, at.xy)) return false;
  float zc = min(zh, hi);
  float dz = tin.z - tout.z;
  float s = dz > 1e-12 ? clamp((tin.z - zc) / dz, 0.0, 1.0) : 0.0;
  hit.tile = tin + s * (tout - tin);
  hit.world = pin + s * (pout - pin);
  hit.crossing = vec3(c.xy, 0.0);
  hit.wo = w;
  return true;
}

vec3 faceNormal(int f) {
  int b = u_oFace + 6 * f;
  vec3 a = shellVertex(si(b));
  return cross(shellVertex(si(b + 1)) - a, shellVertex(si(b + 2)) - a);
}

// Follows o + t d (t > tmin) through the shell from prism `cur` (−1: from outside). With
// `relief`, RenderScene::march: 1 relief (hit filled), 2 absorbed (entering the object's
// underside from outside), 0 miss. Without, the walk of RenderScene::lightAt: 3 when the ray
// leaves the shell (through face h, from prism lastPrism), 0 when no face is found. One function
// for both, called from one place (traceMapped), so the compiler inlines the march once: on
// llvmpipe the shader's compile time grows with every inlined copy.
int walk(vec3 o, vec3 d, float tmin, int cur, bool relief, inout uint rng, inout MarchHit hit,
         out FaceHit h, out int lastPrism) {
  float tnear = tmin;
  int last = -1;
  bool ahead = false;
  vec3 tin = vec3(0.0), pin = vec3(0.0);
  lastPrism = -1;
  h.f = -1;
  h.t = 0.0;
  h.u = 0.0;
  h.v = 0.0;
  for (int step = 0; step < MAX_MARCH; ++step) {
    if (cur < 0 || !nextFace(cur, o, d, tnear, last, h))
      if (!shellIntersect(o, d, tnear, last, h)) return 0;
    int b = u_oFace + 6 * h.f;
    bool intoFront = dot(d, faceNormal(h.f)) > 0.0;
    int from = si(b + (intoFront ? 4 : 3)), to = si(b + (intoFront ? 3 : 4));
    vec3 p = o + d * h.t;
    if (relief && from >= 0 && from == cur) {
      vec3 tout = tileCoords(h.f, from, h.u, h.v);
      if (segmentHit(from, tin, tout, pin, p, d, rng, ahead, hit)) {
        hit.prism = from;
        return 1;
      }
    }
    if (to >= 0) {
      if (relief && cur < 0 && si(b + 5) == 1) return 2;
      if (cur < 0) ahead = false;  // entering the shell from outside
      cur = to;
      if (relief) tin = tileCoords(h.f, to, h.u, h.v);
      pin = p;
    } else {
      if (!relief) {
        lastPrism = from >= 0 ? from : cur;
        return 3;
      }
      cur = -1;
    }
    tnear = h.t + u_eps;
    last = h.f;
  }
  return 0;
}

uniform int u_passes;  // 3: the camera's march, the light's walk, the shadow's march

// The camera ray (o, d): 0 miss (background), 1 relief hit (hit filled; lit and wi: whether the
// light reaches it and its tile-frame direction), 2 absorbed. The light's walk out of the shell
// and the march of another part of the object that may shadow it are further passes of the same
// loop (RenderScene::lightAt).
int traceMapped(vec3 o, vec3 d, inout uint rng, out MarchHit hit, out bool lit, out vec3 wi) {
  lit = false;
  wi = vec3(0, 0, 1);
  hit.prism = -1;
  int result = 0, stage = 0;
  vec3 ro = o, rd = d;
  float rt = 0.0;
  int rc = -1;
  bool relief = true;
  for (int pass = 0; pass < u_passes; ++pass) {
    MarchHit other;
    other.prism = -1;
    FaceHit h;
    int lastPrism;
    int r = walk(ro, rd, rt, rc, relief, rng, other, h, lastPrism);
    if (stage == 0) {  // the camera's ray
      result = r;
      if (r != 1) break;
      hit = other;
      stage = 1;
      ro = hit.world;
      rd = u_light;
      rt = u_eps;
      rc = hit.prism;
      relief = false;
    } else if (stage == 1) {  // out of the shell toward the light
      if (r == 0) {
        // The hit was placed a hair outside the shell: the light leaves from its own prism.
        wi = tileDir(hit.prism, hit.tile, u_light);
        lit = wi.z > 0.0;
        break;
      }
      if (si(u_oFace + 6 * h.f + 5) == 1 || lastPrism < 0) break;  // into the object
      wi = tileDir(lastPrism, tileCoords(h.f, lastPrism, h.u, h.v), u_light);
      if (!(wi.z > 0.0)) break;
      stage = 2;  // does another part of the object cast its shadow?
      rt = h.t + u_eps;
      rc = -1;
      relief = true;
    } else {
      lit = r == 0;
      break;
    }
  }
  return result;
}
