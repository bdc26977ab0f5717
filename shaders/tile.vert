#version 330 core
// The tile view: micro-geometry repeated by an instance offset (3 × 3 tiles).
in vec3 a_position;
in vec3 a_normal;
in vec2 a_uv;
uniform mat4 u_viewProj;
uniform vec2 u_tileSize;
uniform int u_repeat;  // tiles per side (odd)
out vec3 v_normal;
out vec3 v_pos;
flat out int v_part;
void main() {
  int h = u_repeat / 2;
  vec2 off = vec2(float(gl_InstanceID % u_repeat - h), float(gl_InstanceID / u_repeat - h)) * u_tileSize;
  vec3 p = a_position + vec3(off, 0.0);
  v_pos = p;
  v_normal = a_normal;
  v_part = int(a_uv.x + 0.5);
  gl_Position = u_viewProj * vec4(p, 1.0);
}
