#version 330
in vec3 v_rgb;
out vec4 f_color;
void main() { f_color = vec4(v_rgb, 1.0); }
