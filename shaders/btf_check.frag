// The decoder check (tests and `btfstudio --script` "check_glsl"): pixel k decodes query k, six
// floats (x, y in texel units, θi, φi, θo, φo in radians) from u_queries; the output is the raw
// aBRDF in a float framebuffer, compared with the CPU decoder.
uniform samplerBuffer u_queries;
uniform int u_width;
out vec4 o_colour;
void main() {
  int k = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
  float q[6];
  for (int i = 0; i < 6; ++i) q[i] = texelFetch(u_queries, k * 6 + i).r;
  o_colour = vec4(decodeAt(q[0], q[1], q[2], q[3], q[4], q[5]), 1.0);
}
