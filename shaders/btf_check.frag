// The decoder check (tests and `btfstudio --script` "check_glsl"): pixel k decodes query k from
// u_queries — six floats (x, y in texel units, θi, φi, θo, φo in radians), and with texel levels
// four more (the footprint axes a, b in level-0 texels) — into a float framebuffer: the raw
// aBRDF, and with levels the level of detail in alpha; compared with the CPU decoder.
uniform samplerBuffer u_queries;
uniform int u_width;
uniform int u_filtered;  // 1: decodeFiltered over the levels
out vec4 o_colour;
void main() {
  int k = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
  int m = u_filtered == 1 ? 10 : 6;
  float q[10];
  for (int i = 0; i < m; ++i) q[i] = texelFetch(u_queries, k * m + i).r;
  if (u_filtered == 1) {
    float lod;
    vec3 v = decodeFiltered(q[0], q[1], vec2(q[6], q[7]), vec2(q[8], q[9]), q[2], q[3], q[4], q[5],
                            lod);
    o_colour = vec4(v, lod);
  } else {
    o_colour = vec4(decodeAt(q[0], q[1], q[2], q[3], q[4], q[5]), 1.0);
  }
}
