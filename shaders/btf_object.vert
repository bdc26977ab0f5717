#version 330 core
// The object viewer's vertex stage: world position, normal and the BTF's texture coordinates.
in vec3 a_position;
in vec3 a_normal;
in vec2 a_uv;
uniform mat4 u_viewProj;
uniform mat4 u_model;
out vec3 v_pos;
out vec3 v_normal;
out vec2 v_uv;
void main() {
  vec4 p = u_model * vec4(a_position, 1.0);
  v_pos = p.xyz;
  v_normal = mat3(u_model) * a_normal;
  v_uv = a_uv;
  gl_Position = u_viewProj * p;
}
