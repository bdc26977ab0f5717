#version 330 core
in vec3 a_position;
in vec3 a_normal;
in vec2 a_uv;
uniform mat4 u_viewProj;
void main() { gl_Position = u_viewProj * vec4(a_position, 1.0); }
