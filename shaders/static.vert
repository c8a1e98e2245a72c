#version 330
#include "haze.glsl"
uniform mat4 u_light_vp;
uniform vec3 u_sun_dir;
uniform mat4 u_view_proj;
uniform mat4 u_model;
uniform vec3 u_eye;
in vec3 in_pos;
in vec3 in_normal;
in vec4 in_color;
in float in_gloss;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_color;     // linear
out float v_gloss;
out float v_haze;
out vec3 v_light;     // shadow-map coordinates (the sun is orthographic: exact when interpolated)
void main() {
    vec4 wp = u_model * vec4(in_pos, 1.0);
    v_world = wp.xyz;
    v_normal = mat3(u_model) * in_normal;
    v_color = srgb_to_linear(in_color.rgb);
    v_gloss = in_gloss;
    v_haze = haze_keep(wp.xyz, u_eye);
    // normal offset keeps surfaces from shadowing themselves
    v_light = (u_light_vp * vec4(wp.xyz + normalize(v_normal) * 1.2 + u_sun_dir * 0.8, 1.0)).xyz * 0.5 + 0.5;
    gl_Position = u_view_proj * wp;
}
