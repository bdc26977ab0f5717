// The object viewer's fragment stage (after #version, btf_decode.glsl and btf_display.glsl): a
// per-pixel tangent frame from the derivatives of position and uv, the light and view
// directions in that frame, the decoded aBRDF times cos θi (radiance for unit irradiance),
// exposure and tone mapping.
in vec3 v_pos;
in vec3 v_normal;
in vec2 v_uv;
uniform vec3 u_lightDir;  // toward the light (world, unit)
uniform vec3 u_eye;
uniform float u_tiling;   // tiles per unit of uv
uniform float u_exposure;
uniform int u_bilinear;
uniform int u_showLevel;  // 1: the texel level in false colour (levelColour)
out vec4 o_colour;

void main() {
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) n = -n;
  // Tangent along +u from the screen-space derivatives (per pixel, no vertex tangents needed).
  vec3 dp1 = dFdx(v_pos), dp2 = dFdy(v_pos);
  vec2 duv1 = dFdx(v_uv), duv2 = dFdy(v_uv);
  vec3 t = dp1 * duv2.y - dp2 * duv1.y;
  t = t - n * dot(n, t);
  if (dot(t, t) < 1e-20) t = abs(n.x) < 0.9 ? cross(n, vec3(1, 0, 0)) : cross(n, vec3(0, 1, 0));
  t = normalize(t);
  vec3 b = cross(n, t);
  vec3 wo = normalize(u_eye - v_pos);
  vec3 wi = normalize(u_lightDir);
  vec3 lo = vec3(dot(wo, t), dot(wo, b), dot(wo, n));
  vec3 li = vec3(dot(wi, t), dot(wi, b), dot(wi, n));
  // The pixel's footprint in level-0 texels (derivatives in uniform control flow).
  float X = v_uv.x * u_tiling * float(u_nu), Y = v_uv.y * u_tiling * float(u_nv);
  vec2 fa = vec2(dFdx(X), dFdx(Y)), fb = vec2(dFdy(X), dFdy(Y));
  vec3 colour = vec3(0.0);
  float lod = 0.0;
  if (u_showLevel == 1 && u_nLevels > 1) {
    lod = texelLod(length(fa), length(fb));
    o_colour = vec4(pow(levelColour(lod), vec3(1.0 / 2.2)), 1.0);
    return;
  }
  if (li.z > 0.0 && lo.z > 0.0) {
    float thetaI = acos(clamp(li.z, 0.0, 1.0)), phiI = atan(li.y, li.x);
    float thetaO = acos(clamp(lo.z, 0.0, 1.0)), phiO = atan(lo.y, lo.x);
    if (phiI < 0.0) phiI += kTwoPi;
    if (phiO < 0.0) phiO += kTwoPi;
    float x = fract(v_uv.x * u_tiling) * float(u_nu);
    float y = fract(v_uv.y * u_tiling) * float(u_nv);
    vec3 f = u_nLevels > 1   ? decodeFiltered(x, y, fa, fb, thetaI, phiI, thetaO, phiO, lod)
             : u_bilinear == 1 ? decodeAt(x, y, thetaI, phiI, thetaO, phiO)
                               : decodeTexel(int(x) + u_nu * int(y), thetaI, phiI, thetaO, phiO);
    colour = f * li.z;
  }
  vec3 c = toneMap(colour * u_exposure);
  o_colour = vec4(pow(c, vec3(1.0 / 2.2)), 1.0);
}
