#version 330
uniform mat4 u_view_proj;
uniform mat4 u_model;
in vec3 in_pos;
void main() {
    gl_Position = u_view_proj * u_model * vec4(in_pos, 1.0);
}
