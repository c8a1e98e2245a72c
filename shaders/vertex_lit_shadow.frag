#version 330
// The vertex-lit batsman (lit_vertex.vert, PIXEL_SHADOW): one shadow tap per pixel scales
// the sun's part of the vertex lighting, then the tone curve and the haze.
#include "lighting.glsl"
in vec3 v_rest;
in vec3 v_sun;
in vec3 v_light;
in float v_keep;
out vec4 f_color;
void main() {
    float sh = mix(1.0, texture(u_shadow_map, v_light), u_shadow_on);
    f_color = vec4(mix(u_haze_color, tone(v_rest + v_sun * sh), v_keep), 1.0);
}
