#version 330
// GPU linear-blend skinning: one bone-matrix array per draw, static vertex buffers.
#include "haze.glsl"
uniform mat4 u_light_vp;
uniform vec3 u_sun_dir;
uniform mat4 u_view_proj;
uniform mat4 u_bones[32];
uniform vec3 u_eye;
in vec3 in_pos;
in vec3 in_normal;
in vec4 in_color;
in float in_gloss;
in ivec4 in_joints;
in vec4 in_weights;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_color;     // linear
out float v_gloss;
out float v_haze;
out vec3 v_light;     // shadow-map coordinates (the sun is orthographic: exact when interpolated)
void main() {
    mat4 m = u_bones[in_joints.x] * in_weights.x + u_bones[in_joints.y] * in_weights.y
           + u_bones[in_joints.z] * in_weights.z + u_bones[in_joints.w] * in_weights.w;
    vec4 wp = m * vec4(in_pos, 1.0);
    v_world = wp.xyz;
    v_normal = mat3(m) * in_normal;
    v_color = srgb_to_linear(in_color.rgb);
    v_gloss = in_gloss;
    v_haze = haze_keep(wp.xyz, u_eye);
    // normal offset keeps surfaces from shadowing themselves
    v_light = (u_light_vp * vec4(wp.xyz + normalize(v_normal) * 1.2 + u_sun_dir * 0.8, 1.0)).xyz * 0.5 + 0.5;
    gl_Position = u_view_proj * wp;
}
