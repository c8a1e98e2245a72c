#version 330
// The ground is flat geometry with vertex colours (outfield, mown stripes,
// pitch strip, creases) drawn in painter's order: no per-pixel pattern maths.
#include "haze.glsl"
uniform mat4 u_view_proj;
in vec3 in_pos;
in vec3 in_color;
out vec3 v_world;
out vec3 v_color;   // linear
void main() {
    v_world = in_pos;
    v_color = srgb_to_linear(in_color);
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
