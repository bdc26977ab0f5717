#version 330 core
// Flat-coloured lines (tile outline, light direction).
uniform vec3 u_colour;
out vec4 o_colour;
void main() { o_colour = vec4(u_colour, 1.0); }
