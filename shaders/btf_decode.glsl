// Decoding a compressed BTF (.cbtf, docs/compression.md) on the GPU: the arrays are texture
// buffers (R16F holds the file's half bits, R32F its floats); direction interpolation follows
// DirectionSet::interpolate (ring-linear in θ, linear in φ inside a ring); texels are bilinear
// (periodic). Included, after the #version line, by btf_object.frag and btf_check.frag.
#define MAX_RINGS 48
uniform int u_nRings;
uniform float u_ringTheta[MAX_RINGS];
uniform float u_ringPhi0[MAX_RINGS];
uniform int u_ringCount[MAX_RINGS];
uniform int u_ringFirst[MAX_RINGS];
uniform int u_nu;
uniform int u_nv;
uniform int u_n;      // directions in the set
uniform int u_codec;  // 0 nmf, 1 svd, 2 perview, 3 lpca, 4 tensor, 5 neural
uniform int u_ycc;    // 1: channels are Y, U, V
uniform int u_c0[3];  // nmf: Cv; linear codecs: C
uniform int u_c1[3];  // nmf: Cl
uniform int u_k[3];   // nmf: slots K
// Channel ch's arrays: nmf basis_view, basis_light, coef_view, coef_light; linear codecs use
// a = basis, b = coef; tensor: view, light, core and the channel's cluster table (7 floats per
// cluster: Rv, Rl, Rt, the offsets of its view, light and core blocks, and of its G block in u_tM
// or -1). For tensor, u_cluster holds 3 floats per texel (cluster, offset in coef, offset in u_tM
// or -1), u_tcoef the coefficients, and u_tM either every cluster's projected cores
// G[(v·n + l)·Rt + j] = x_vᵀ core_j y_l (when they fit) or the per-texel Rv × Rl matrices the CPU
// decoder also uses (TensorGpuTables).
uniform samplerBuffer u_a0, u_b0, u_c0buf, u_d0;
uniform samplerBuffer u_a1, u_b1, u_c1buf, u_d1;
uniform samplerBuffer u_a2, u_b2, u_c2buf, u_d2;
uniform samplerBuffer u_cluster;
uniform samplerBuffer u_tcoef, u_tM;

const float kTwoPi = 6.283185307179586;

void inRing(int r, float wRing, float phi, inout int k, inout int idx[4], inout float w[4]) {
  int cnt = u_ringCount[r];
  if (cnt == 1) {
    idx[k] = u_ringFirst[r];
    w[k] = wRing;
    k++;
    return;
  }
  float stp = kTwoPi / float(cnt);
  float x = (phi - u_ringPhi0[r]) / stp;
  x -= floor(x / float(cnt)) * float(cnt);
  float j0f = floor(x);
  float f = x - j0f;
  int j0 = int(j0f) % cnt;
  int j1 = (j0 + 1) % cnt;
  idx[k] = u_ringFirst[r] + j0;
  w[k] = wRing * (1.0 - f);
  k++;
  idx[k] = u_ringFirst[r] + j1;
  w[k] = wRing * f;
  k++;
}

// Up to four directions and weights (summing to 1) at (θ, φ) in radians.
void interpolateDirs(float theta, float phi, out int idx[4], out float w[4]) {
  for (int i = 0; i < 4; ++i) {
    idx[i] = 0;
    w[i] = 0.0;
  }
  int k = 0;
  if (theta <= u_ringTheta[0] || u_nRings == 1) {
    inRing(0, 1.0, phi, k, idx, w);
  } else if (theta >= u_ringTheta[u_nRings - 1]) {
    inRing(u_nRings - 1, 1.0, phi, k, idx, w);
  } else {
    int r = 0;
    while (r + 1 < u_nRings && u_ringTheta[r + 1] < theta) ++r;
    float f = (theta - u_ringTheta[r]) / (u_ringTheta[r + 1] - u_ringTheta[r]);
    inRing(r, 1.0 - f, phi, k, idx, w);
    inRing(r + 1, f, phi, k, idx, w);
  }
}

float fetch(samplerBuffer b, int i) { return texelFetch(b, i).r; }

float channelNmf(samplerBuffer bv, samplerBuffer bl, samplerBuffer cv, samplerBuffer cl, int Cv,
                 int Cl, int K, int t, int o, int l) {
  float x = 0.0;
  for (int j = 0; j < K; ++j) {
    float a = 0.0, b = 0.0;
    for (int q = 0; q < Cv; ++q) a += fetch(bv, o * Cv + q) * fetch(cv, (t * K + j) * Cv + q);
    for (int q = 0; q < Cl; ++q) b += fetch(bl, l * Cl + q) * fetch(cl, (t * K + j) * Cl + q);
    x += a * b;
  }
  return x;
}

float channelLinear(samplerBuffer basis, samplerBuffer coef, int C, int t, int o, int l) {
  int k = o * u_n + l;
  int row = k, crow = t * C;
  if (u_codec == 2) crow = (t * u_n + o) * C;
  if (u_codec == 3) row = int(fetch(u_cluster, t) + 0.5) * u_n * u_n + k;
  float x = 0.0;
  for (int q = 0; q < C; ++q) x += fetch(basis, row * C + q) * fetch(coef, crow + q);
  return x;
}

float channelValue(int ch, int t, int o, int l) {
  if (u_codec == 0) {
    if (ch == 0) return channelNmf(u_a0, u_b0, u_c0buf, u_d0, u_c0[0], u_c1[0], u_k[0], t, o, l);
    if (ch == 1) return channelNmf(u_a1, u_b1, u_c1buf, u_d1, u_c0[1], u_c1[1], u_k[1], t, o, l);
    return channelNmf(u_a2, u_b2, u_c2buf, u_d2, u_c0[2], u_c1[2], u_k[2], t, o, l);
  }
  if (ch == 0) return channelLinear(u_a0, u_b0, u_c0[0], t, o, l);
  if (ch == 1) return channelLinear(u_a1, u_b1, u_c0[1], t, o, l);
  return channelLinear(u_a2, u_b2, u_c0[2], t, o, l);
}

// One stored value, RGB, clamped to >= 0 like the CPU decoder.
vec3 decodeValue(int t, int o, int l) {
  vec3 c = vec3(channelValue(0, t, o, l), channelValue(1, t, o, l), channelValue(2, t, o, l));
  vec3 rgb = u_ycc == 1 ? vec3(c.x + c.y, c.x - c.y - c.z, c.x + c.z) : c;
  return max(rgb, vec3(0.0));
}

// neural (codec_neural.cpp): u_a0 the network's parameters (per layer W, out × in column-major,
// then b), u_b0 the latents (texels × L), u_c0buf the gains. value = g_t · max(0, cos θ_i) ·
// net(z_t, features(ω_i, ω_o)) in the colour model, then RGB and clamped like the CPU. Layer 0's
// direction part (W·f + b) is formed once per lookup and shared by the bilinear texels.
#define NN_MAX 128
#define NN_LAYERS 9
uniform int u_nnLayers;            // layers (hidden layers + 1)
uniform int u_nnSize[NN_LAYERS + 1];
uniform int u_nnW[NN_LAYERS];      // offsets of W and b per layer in u_a0
uniform int u_nnB[NN_LAYERS];
uniform int u_nnEnc;               // 0 raw (6 features), 1 halfdiff (12), 2 fourier (36)
uniform int u_nnMinimal;           // 1: ω_i into h's frame by the minimal rotation (half_frame)
float nnDir[NN_MAX];
float nnA[NN_MAX];
float nnB[NN_MAX];

int nnFeatures(float thetaI, float phiI, float thetaO, float phiO, out float f[36]) {
  for (int i = 0; i < 36; ++i) f[i] = 0.0;
  vec3 wi = vec3(sin(thetaI) * cos(phiI), sin(thetaI) * sin(phiI), cos(thetaI));
  vec3 wo = vec3(sin(thetaO) * cos(phiO), sin(thetaO) * sin(phiO), cos(thetaO));
  f[0] = wi.x; f[1] = wi.y; f[2] = wi.z;
  f[3] = wo.x; f[4] = wo.y; f[5] = wo.z;
  if (u_nnEnc == 0) return 6;
  vec3 h = wi + wo;
  float len = length(h);
  h = len > 1e-9 ? h / len : vec3(0.0, 0.0, 1.0);
  f[6] = h.x; f[7] = h.y; f[8] = h.z;
  float th = acos(clamp(h.z, -1.0, 1.0)), ph = atan(h.y, h.x);
  if (abs(h.x) + abs(h.y) == 0.0) ph = 0.0;
  float cp = cos(ph), sp = sin(ph), ct = cos(th), st = sin(th);
  float x = wi.x * cp + wi.y * sp, y = -wi.x * sp + wi.y * cp, z = wi.z;
  float dx = x * ct - z * st, dy = y;
  if (u_nnMinimal == 1) {  // and back by φ_h about z: continuous where h meets the normal
    f[9] = dx * cp - dy * sp; f[10] = dx * sp + dy * cp;
  } else {
    f[9] = dx; f[10] = dy;
  }
  f[11] = x * st + z * ct;
  if (u_nnEnc == 1) return 12;
  for (int i = 0; i < 12; ++i) {
    f[12 + 2 * i] = sin(3.14159265358979 * f[i]);
    f[13 + 2 * i] = cos(3.14159265358979 * f[i]);
  }
  return 36;
}

// Layer 0's direction part at one pair into nnDir; returns max(0, cos θ_i).
float nnDirection(float thetaI, float phiI, float thetaO, float phiO) {
  float f[36];
  int D = nnFeatures(thetaI, phiI, thetaO, phiO, f);
  int out0 = u_nnSize[1], L = u_nnSize[0] - D;
  for (int j = 0; j < out0; ++j) {
    float s = fetch(u_a0, u_nnB[0] + j);
    for (int i = 0; i < D; ++i) s += fetch(u_a0, u_nnW[0] + (L + i) * out0 + j) * f[i];
    nnDir[j] = s;
  }
  return max(f[2], 0.0);
}

// Texel t's value at the pair whose direction part is in nnDir.
vec3 nnTexel(int t, float cosine) {
  float g = fetch(u_c0buf, t);
  if (g == 0.0) return vec3(0.0);
  int D = u_nnEnc == 0 ? 6 : u_nnEnc == 1 ? 12 : 36;
  int L = u_nnSize[0] - D, out0 = u_nnSize[1];
  for (int j = 0; j < out0; ++j) {
    float s = nnDir[j];
    for (int q = 0; q < L; ++q) s += fetch(u_a0, u_nnW[0] + q * out0 + j) * fetch(u_b0, t * L + q);
    nnA[j] = u_nnLayers > 1 ? max(s, 0.0) : s;
  }
  for (int l = 1; l < u_nnLayers; ++l) {
    int nin = u_nnSize[l], nout = u_nnSize[l + 1];
    bool last = l == u_nnLayers - 1;
    for (int j = 0; j < nout; ++j) {
      float s = fetch(u_a0, u_nnB[l] + j);
      for (int i = 0; i < nin; ++i) s += fetch(u_a0, u_nnW[l] + i * nout + j) * nnA[i];
      nnB[j] = last ? s : max(s, 0.0);
    }
    for (int j = 0; j < nout; ++j) nnA[j] = nnB[j];
  }
  vec3 c = vec3(nnA[0], nnA[1], nnA[2]) * (g * cosine);
  vec3 rgb = u_ycc == 1 ? vec3(c.x + c.y, c.x - c.y - c.z, c.x + c.z) : c;
  return max(rgb, vec3(0.0));
}

vec3 decodeFactorTexels(int tt[4], float tw[4], float thetaI, float phiI, float thetaO,
                        float phiO);
bool nmfFast();

// aBRDF of texel t at any directions (radians): 4 × 4 interpolated values.
vec3 decodeTexel(int t, float thetaI, float phiI, float thetaO, float phiO) {
  if (u_codec == 5) return nnTexel(t, nnDirection(thetaI, phiI, thetaO, phiO));
  if (nmfFast() || u_codec == 4) {
    int tt[4] = int[4](t, t, t, t);
    float tw[4] = float[4](1.0, 0.0, 0.0, 0.0);
    return decodeFactorTexels(tt, tw, thetaI, phiI, thetaO, phiO);
  }
  int li[4], vi[4];
  float lw[4], vw[4];
  interpolateDirs(thetaI, phiI, li, lw);
  interpolateDirs(thetaO, phiO, vi, vw);
  vec3 acc = vec3(0.0);
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      float w = vw[a] * lw[b];
      if (w > 0.0) acc += w * decodeValue(t, vi[a], li[b]);
    }
  return acc;
}

// nmf per texel: the K view factors at the 4 interpolation views and the K light factors at the
// 4 lights are formed once (4·K·(Cv + Cl) products), then the 16 direction pairs cost K each —
// instead of 16·K·(Cv + Cl). Each pair is converted to RGB and clamped before the weighted sum,
// exactly as the CPU decoder does.
#define MAX_K 16
void nmfPairs(samplerBuffer bv, samplerBuffer bl, samplerBuffer cv, samplerBuffer cl, int Cv, int Cl,
              int K, int t, int vi[4], float vw[4], int li[4], float lw[4], out float val[16]) {
  float A[4 * MAX_K], B[4 * MAX_K];
  for (int a = 0; a < 4; ++a)
    for (int j = 0; j < K; ++j) {
      float x = 0.0, y = 0.0;
      if (vw[a] > 0.0)
        for (int q = 0; q < Cv; ++q) x += fetch(bv, vi[a] * Cv + q) * fetch(cv, (t * K + j) * Cv + q);
      if (lw[a] > 0.0)
        for (int q = 0; q < Cl; ++q) y += fetch(bl, li[a] * Cl + q) * fetch(cl, (t * K + j) * Cl + q);
      A[a * MAX_K + j] = x;
      B[a * MAX_K + j] = y;
    }
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      float x = 0.0;
      for (int j = 0; j < K; ++j) x += A[a * MAX_K + j] * B[b * MAX_K + j];
      val[a * 4 + b] = x;
    }
}
// The 16 (view, light) pairs of one texel, each channel triple converted to RGB and clamped
// before the weighted sum, exactly as the CPU decoder does.
vec3 combinePairs(float c0[16], float c1[16], float c2[16], float vw[4], float lw[4]) {
  vec3 acc = vec3(0.0);
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      float w = vw[a] * lw[b];
      if (w <= 0.0) continue;
      vec3 c = vec3(c0[a * 4 + b], c1[a * 4 + b], c2[a * 4 + b]);
      vec3 rgb = u_ycc == 1 ? vec3(c.x + c.y, c.x - c.y - c.z, c.x + c.z) : c;
      acc += w * max(rgb, vec3(0.0));
    }
  return acc;
}
bool nmfFast() { return u_codec == 0 && max(max(u_k[0], u_k[1]), u_k[2]) <= MAX_K; }

// tensor per texel and channel: M (Rv × Rl, from u_tM or formed from the coefficients and the
// core), then M·y for the 4 interpolation lights (4·Rv·Rl products) and xᵀ(M·y) for the 16
// pairs. Each pair is converted to RGB and clamped before the weighted sum, like the CPU.
#define MAX_TR 128
#define MAX_RT 32
int tabInt(samplerBuffer tab, int k, int i) { return int(floor(fetch(tab, k * 7 + i) + 0.5)); }
void tensorPairs(samplerBuffer view, samplerBuffer light, samplerBuffer core, samplerBuffer tab,
                 int t, int cOff, int mOff, int vi[4], float vw[4], int li[4], float lw[4],
                 out float val[16]) {
  for (int i = 0; i < 16; ++i) val[i] = 0.0;
  int k = int(fetch(u_cluster, t * 3) + 0.5);
  int Rv = tabInt(tab, k, 0), Rl = tabInt(tab, k, 1), Rt = tabInt(tab, k, 2);
  if (Rt == 0) return;
  int oV = tabInt(tab, k, 3), oL = tabInt(tab, k, 4), oC = tabInt(tab, k, 5);
  int oG = tabInt(tab, k, 6);
  if (oG >= 0) {
    // The cluster's core projected on both factor rows (u_tM holds the G blocks): Rt products of
    // the texel's coefficients per pair.
    float u[MAX_RT];
    for (int j = 0; j < Rt; ++j) u[j] = fetch(u_tcoef, cOff + j);
    for (int p = 0; p < 4; ++p) {
      if (vw[p] <= 0.0) continue;
      for (int q = 0; q < 4; ++q) {
        if (lw[q] <= 0.0) continue;
        int base = oG + (vi[p] * u_n + li[q]) * Rt;
        float s = 0.0;
        for (int j = 0; j < Rt; ++j) s += u[j] * fetch(u_tM, base + j);
        val[p * 4 + q] = s;
      }
    }
    return;
  }
  float Y[4 * MAX_TR], MY[4 * MAX_TR];
  for (int q = 0; q < 4; ++q)
    for (int b = 0; b < Rl; ++b) Y[q * MAX_TR + b] = lw[q] > 0.0 ? fetch(light, oL + li[q] * Rl + b) : 0.0;
  for (int i = 0; i < 4 * MAX_TR; ++i) MY[i] = 0.0;
  for (int a = 0; a < Rv; ++a)
    for (int b = 0; b < Rl; ++b) {
      float m = 0.0;
      if (mOff >= 0) {
        m = fetch(u_tM, mOff + a * Rl + b);
      } else {
        for (int j = 0; j < Rt; ++j) m += fetch(u_tcoef, cOff + j) * fetch(core, oC + (j * Rv + a) * Rl + b);
      }
      for (int q = 0; q < 4; ++q) MY[q * MAX_TR + a] += m * Y[q * MAX_TR + b];
    }
  for (int p = 0; p < 4; ++p) {
    if (vw[p] <= 0.0) continue;
    for (int a = 0; a < Rv; ++a) {
      float x = fetch(view, oV + vi[p] * Rv + a);
      for (int q = 0; q < 4; ++q) val[p * 4 + q] += x * MY[q * MAX_TR + a];
    }
  }
}
// The factorised codecs (nmf within MAX_K, tensor) decode the 16 direction pairs of each of the
// four bilinear texels together.
vec3 decodeFactorTexels(int tt[4], float tw[4], float thetaI, float phiI, float thetaO,
                        float phiO) {
  int li[4], vi[4];
  float lw[4], vw[4];
  interpolateDirs(thetaI, phiI, li, lw);
  interpolateDirs(thetaO, phiO, vi, vw);
  vec3 acc = vec3(0.0);
  for (int k = 0; k < 4; ++k) {
    if (tw[k] <= 0.0) continue;
    float c0[16], c1[16], c2[16];
    if (u_codec == 4) {
      int t = tt[k];
      int cl = int(fetch(u_cluster, t * 3) + 0.5);
      int cOff = int(fetch(u_cluster, t * 3 + 1) + 0.5);
      int mOff = int(floor(fetch(u_cluster, t * 3 + 2) + 0.5));
      // Channel 1 and 2 start after the earlier channels' coefficients and matrices.
      int rt0 = tabInt(u_d0, cl, 2), rt1 = tabInt(u_d1, cl, 2);
      int m0 = tabInt(u_d0, cl, 0) * tabInt(u_d0, cl, 1), m1 = tabInt(u_d1, cl, 0) * tabInt(u_d1, cl, 1);
      tensorPairs(u_a0, u_b0, u_c0buf, u_d0, t, cOff, mOff, vi, vw, li, lw, c0);
      tensorPairs(u_a1, u_b1, u_c1buf, u_d1, t, cOff + rt0, mOff < 0 ? -1 : mOff + m0, vi, vw, li, lw, c1);
      tensorPairs(u_a2, u_b2, u_c2buf, u_d2, t, cOff + rt0 + rt1, mOff < 0 ? -1 : mOff + m0 + m1, vi,
                  vw, li, lw, c2);
    } else {
      nmfPairs(u_a0, u_b0, u_c0buf, u_d0, u_c0[0], u_c1[0], u_k[0], tt[k], vi, vw, li, lw, c0);
      nmfPairs(u_a1, u_b1, u_c1buf, u_d1, u_c0[1], u_c1[1], u_k[1], tt[k], vi, vw, li, lw, c1);
      nmfPairs(u_a2, u_b2, u_c2buf, u_d2, u_c0[2], u_c1[2], u_k[2], tt[k], vi, vw, li, lw, c2);
    }
    acc += tw[k] * combinePairs(c0, c1, c2, vw, lw);
  }
  return acc;
}

// The four texels around (x, y) in the texel units of an nu × nv grid whose texels start at
// pyramid texel `first` (a level; 0 for level 0) and their bilinear weights (texel centres at
// integer + ½, periodic).
void bilinearTexels(float x, float y, int nu, int nv, int first, out int tt[4], out float tw[4]) {
  float fx = x - 0.5, fy = y - 0.5;
  float x0 = floor(fx), y0 = floor(fy);
  float ax = fx - x0, ay = fy - y0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      int u = int(mod(x0 + float(i), float(nu)));
      int v = int(mod(y0 + float(j), float(nv)));
      tt[j * 2 + i] = first + u + nu * v;
      tw[j * 2 + i] = (i == 1 ? ax : 1.0 - ax) * (j == 1 ? ay : 1.0 - ay);
    }
}

// At a position (x, y) of that grid, bilinear between texel centres.
vec3 decodeAtGrid(float x, float y, int nu, int nv, int first, float thetaI, float phiI,
                  float thetaO, float phiO) {
  int tt[4];
  float tw[4];
  bilinearTexels(x, y, nu, nv, first, tt, tw);
  if (nmfFast() || u_codec == 4) return decodeFactorTexels(tt, tw, thetaI, phiI, thetaO, phiO);
  // neural: continuous in direction (no interpolation between the set's), one direction part.
  float cosine = u_codec == 5 ? nnDirection(thetaI, phiI, thetaO, phiO) : 0.0;
  vec3 acc = vec3(0.0);
  for (int k = 0; k < 4; ++k) {
    if (tw[k] <= 0.0) continue;
    acc += tw[k] * (u_codec == 5 ? nnTexel(tt[k], cosine)
                                 : decodeTexel(tt[k], thetaI, phiI, thetaO, phiO));
  }
  return acc;
}

vec3 decodeAt(float x, float y, float thetaI, float phiI, float thetaO, float phiO) {
  return decodeAtGrid(x, y, u_nu, u_nv, 0, thetaI, phiI, thetaO, phiO);
}

// Texel levels (a --mip file, docs/mip.md): level k is a u_levelNu[k] × u_levelNv[k] grid whose
// texels start at pyramid texel u_levelFirst[k]. a, b: the pixel's footprint axes in level-0
// texels; lod = log2 of the longer, clamped to the levels (btf::texelFilter with maxAniso 0).
#define MAX_LEVELS 16
uniform int u_nLevels;  // 1: level 0 only
uniform int u_levelNu[MAX_LEVELS];
uniform int u_levelNv[MAX_LEVELS];
uniform int u_levelFirst[MAX_LEVELS];

float texelLod(float la, float lb) {
  return clamp(log2(max(max(la, lb), 1e-12)), 0.0, float(u_nLevels - 1));
}

vec3 decodeLevel(int k, float x, float y, float thetaI, float phiI, float thetaO, float phiO) {
  float sx = float(u_levelNu[k]) / float(u_nu), sy = float(u_levelNv[k]) / float(u_nv);
  return decodeAtGrid(x * sx, y * sy, u_levelNu[k], u_levelNv[k], u_levelFirst[k], thetaI, phiI,
                      thetaO, phiO);
}

// (x, y) in level-0 texel units; `lod` receives the level of detail used. One tap at the two
// levels around lod (isotropic trilinear: the footprint's long axis sets the level; the CPU
// renderer's anisotropic taps, btf::texelFilter with maxAniso > 0, are not here — llvmpipe
// (Mesa 22.3) summed a loop of tensor decodes wrongly, which check_glsl caught).
vec3 decodeFiltered(float x, float y, vec2 a, vec2 b, float thetaI, float phiI, float thetaO,
                    float phiO, out float lod) {
  lod = 0.0;
  if (u_nLevels <= 1) return decodeAt(x, y, thetaI, phiI, thetaO, phiO);
  lod = texelLod(length(a), length(b));
  int top = u_nLevels - 1;
  int l0 = min(int(lod), top), l1 = min(l0 + 1, top);
  float f = l1 != l0 ? lod - float(l0) : 0.0;
  vec3 v0 = decodeLevel(l0, x, y, thetaI, phiI, thetaO, phiO);
  vec3 v1 = decodeLevel(l1, x, y, thetaI, phiI, thetaO, phiO);
  return mix(v0, v1, f);
}
