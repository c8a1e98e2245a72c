#version 330
// The batsman when he is small on screen (his coarser level of detail): the same
// lighting as lit.frag, evaluated per vertex. On llvmpipe a pixel-lit, shadow-mapped
// fragment costs ~10x a flat one and small triangles shade whole 4x4 pixel blocks, so
// this pass costs a fraction; at a few pixels a triangle the result looks the same.
// With PIXEL_SHADOW defined (the batsman) the shadow is looked up per pixel.
#include "lighting.glsl"
#include "haze.glsl"
uniform mat4 u_light_vp;
uniform mat4 u_view_proj;
uniform mat4 u_model;
uniform vec3 u_tint;
uniform vec3 u_emissive;
in vec3 in_pos;
in vec3 in_normal;
in vec4 in_color;
in float in_gloss;
#ifdef PIXEL_SHADOW
// The shadow tap per pixel (vertex_lit_shadow.frag): sharper self-shadow, and llvmpipe
// need not finish the shadow map before it runs this shader (on the drawing thread).
out vec3 v_rest;      // linear colour the sun's shadow does not scale
out vec3 v_sun;       // and the part it does
out vec3 v_light;     // shadow-map coordinates
out float v_keep;     // haze: the fraction of the colour left
#else
out vec3 v_rgb;       // display colour, toned and hazed
#endif
void main() {
    vec4 wp = u_model * vec4(in_pos, 1.0);
    vec3 n = normalize(mat3(u_model) * in_normal);
    vec3 light = (u_light_vp * vec4(wp.xyz + n * 1.2 + u_sun_dir * 0.8, 1.0)).xyz * 0.5 + 0.5;
    vec3 rest;
    vec3 sun = shade_split(srgb_to_linear(in_color.rgb) * u_tint, n, wp.xyz, in_gloss, rest);
#ifdef PIXEL_SHADOW
    v_rest = rest + u_emissive;
    v_sun = sun;
    v_light = light;
    v_keep = haze_keep(wp.xyz, u_eye);
#else
    float sh = mix(1.0, texture(u_shadow_map, light), u_shadow_on);
    v_rgb = mix(u_haze_color, tone(rest + sun * sh + u_emissive), haze_keep(wp.xyz, u_eye));
#endif
    gl_Position = u_view_proj * wp;
}
