// What the object views share for display (after btf_decode.glsl): the texel levels' false
// colour and the tone maps.
uniform int u_toneMap;  // 0 clamp, 1 Reinhard, 2 ACES-like filmic

// btf::levelColour: 0 blue, 1 cyan, 2 green, 3 yellow, 4 red, 5+ magenta.
vec3 levelColour(float level) {
  vec3 ramp[6] = vec3[6](vec3(0.1, 0.2, 1.0), vec3(0.0, 0.9, 0.9), vec3(0.1, 0.9, 0.1),
                         vec3(1.0, 0.9, 0.0), vec3(1.0, 0.15, 0.0), vec3(0.9, 0.0, 0.9));
  float l = clamp(level, 0.0, 5.0);
  int k = min(4, int(l));
  return mix(ramp[k], ramp[k + 1], l - float(k));
}

vec3 toneMap(vec3 c) {
  if (u_toneMap == 1) return c / (1.0 + c);
  if (u_toneMap == 2) {
    vec3 a = c * (2.51 * c + 0.03), b = c * (2.43 * c + 0.59) + 0.14;
    return clamp(a / b, 0.0, 1.0);
  }
  return clamp(c, 0.0, 1.0);
}
