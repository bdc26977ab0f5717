#version 330 core
// Headlight-plus-key shading of the tile's triangles; the selected part is tinted; `u_pick`
// writes part ids instead (colour-coded picking).
in vec3 v_normal;
in vec3 v_pos;
flat in int v_part;
uniform vec3 u_lightDir;
uniform int u_selected;
uniform int u_pick;
uniform vec3 u_colours[16];
out vec4 o_colour;
void main() {
  if (u_pick == 1) {
    int id = v_part + 1;
    o_colour = vec4(float(id & 255) / 255.0, float((id >> 8) & 255) / 255.0, 0.0, 1.0);
    return;
  }
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) n = -n;
  vec3 base = u_colours[v_part % 16];
  float key = max(dot(n, normalize(u_lightDir)), 0.0);
  vec3 c = base * (0.25 + 0.75 * key);
  if (v_part == u_selected) c = mix(c, vec3(1.0, 0.8, 0.2), 0.45);
  o_colour = vec4(pow(c, vec3(1.0 / 2.2)), 1.0);
}
