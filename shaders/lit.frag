#version 330
#include "lighting.glsl"
// u_mode 0: lit and shadowed; 1: translucent ghost (source pose)
uniform int u_mode;
uniform float u_alpha;
uniform vec3 u_tint;        // multiplies the albedo
uniform vec3 u_emissive;    // linear, added (e.g. highlighted target)
uniform vec3 u_ghost_color; // linear
in vec3 v_world;
in vec3 v_normal;
in vec3 v_color;
in float v_gloss;
in float v_haze;
in vec3 v_light;
out vec4 f_color;
void main() {
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;   // open shells (helmet) are drawn double-sided
    if (u_mode == 1) {
        vec3 v = normalize(u_eye - v_world);
        float r = 1.0 - abs(dot(n, v));
        float rim = r * r;
        vec3 c = u_ghost_color * (0.35 + 0.9 * max(dot(n, u_sun_dir), 0.0)) + rim * u_ghost_color;
        f_color = vec4(mix(u_haze_color, tone(c), v_haze), u_alpha * (0.6 + 0.4 * rim));
        return;
    }
    float sh = mix(1.0, texture(u_shadow_map, v_light), u_shadow_on);
    vec3 c = shade(v_color * u_tint, n, v_world, v_gloss, sh) + u_emissive;
    f_color = vec4(mix(u_haze_color, tone(c), v_haze), 1.0);
}
