#version 330
uniform mat4 u_view_proj;
in vec3 in_pos;
in vec4 in_color;
in float in_width;
out vec4 g_color;
out float g_width;
void main() {
    g_color = in_color;
    g_width = in_width;
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
