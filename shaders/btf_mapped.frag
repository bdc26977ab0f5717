// The object viewer's mapped view (after #version, btf_decode.glsl, btf_display.glsl and
// btf_shell.glsl), a full-screen pass: per pixel, the camera ray through its centre (the CPU
// renderer's camera, RenderScene::cameraFrame) marched through the shell; on a relief hit the
// light direction from lightAt and the decoded aBRDF at the crossing of the reference plane
// times cos θi (radiance for unit irradiance); a ray that leaves the shell is background (the
// silhouette). u_raw = 1 writes linear radiance and coverage (the GPU-vs-CPU check).
uniform vec3 u_camPos, u_camFwd, u_camRight, u_camUp;
uniform float u_hw, u_hh;
uniform int u_persp;
uniform vec2 u_size;  // the framebuffer's pixels
uniform float u_exposure;
uniform int u_bilinear;
uniform int u_showLevel;
uniform int u_raw;
out vec4 o_colour;

void main() {
  // Screen coordinates of the pixel's centre: x right, y up (row 0 of the CPU's image is the top).
  float sx = gl_FragCoord.x / u_size.x * 2.0 - 1.0;
  float sy = gl_FragCoord.y / u_size.y * 2.0 - 1.0;
  vec3 o, d;
  if (u_persp == 1) {
    o = u_camPos;
    d = normalize(u_camFwd + u_camRight * (sx * u_hw) + u_camUp * (sy * u_hh));
  } else {
    o = u_camPos + u_camRight * (sx * u_hw) + u_camUp * (sy * u_hh);
    d = u_camFwd;
  }
  uint rng = uint(gl_FragCoord.x) * 1973u + uint(gl_FragCoord.y) * 9277u + 26699u;
  MarchHit hit;
  bool lit;
  vec3 wi;
  int m = traceMapped(o, d, rng, hit, lit, wi);
  // The footprint from the crossings' screen derivatives (outside any branch).
  vec2 c = m == 1 ? hit.crossing.xy : vec2(0.0);
  float X = c.x / u_Lx * float(u_nu), Y = c.y / u_Ly * float(u_nv);
  vec2 fa = vec2(dFdx(X), dFdx(Y)), fb = vec2(dFdy(X), dFdy(Y));
  vec3 colour = vec3(0.0);
  float lod = 0.0;
  if (m == 1 && u_showLevel == 1 && u_nLevels > 1) {
    lod = texelLod(length(fa), length(fb));
    o_colour = vec4(pow(levelColour(lod), vec3(1.0 / 2.2)), 1.0);
    return;
  }
  if (m == 1 && lit) {
    vec3 wo = hit.wo;
    float thetaI = acos(clamp(wi.z, 0.0, 1.0)), phiI = atan(wi.y, wi.x);
    float thetaO = acos(clamp(wo.z, 0.0, 1.0)), phiO = atan(wo.y, wo.x);
    if (phiI < 0.0) phiI += kTwoPi;
    if (phiO < 0.0) phiO += kTwoPi;
    float x = X - floor(X / float(u_nu)) * float(u_nu);
    float y = Y - floor(Y / float(u_nv)) * float(u_nv);
    vec3 f = u_nLevels > 1   ? decodeFiltered(x, y, fa, fb, thetaI, phiI, thetaO, phiO, lod)
             : u_bilinear == 1 ? decodeAt(x, y, thetaI, phiI, thetaO, phiO)
                               : decodeTexel(min(int(x), u_nu - 1) + u_nu * min(int(y), u_nv - 1),
                                             thetaI, phiI, thetaO, phiO);
    colour = f * wi.z;
  }
  if (u_raw == 1) {
    o_colour = vec4(colour, m == 0 ? 0.0 : 1.0);
    return;
  }
  if (m == 0) discard;  // the background: the silhouette
  vec3 t = toneMap(colour * u_exposure);
  o_colour = vec4(pow(t, vec3(1.0 / 2.2)), 1.0);
}
