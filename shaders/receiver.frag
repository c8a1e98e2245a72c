#version 330
// Multiplied over the lit ground (blend DST_COLOR, ZERO): 4 hardware-PCF taps.
uniform sampler2DShadow u_shadow_map;
uniform float u_shadow_texel;
uniform vec3 u_shadow_tint;   // display-space ratio shadowed / lit ground
in vec3 v_light;
out vec4 f_color;
void main() {
    float o = 0.8 * u_shadow_texel;
    float s = texture(u_shadow_map, v_light + vec3(-o, -o, 0.0));
    s += texture(u_shadow_map, v_light + vec3(o, -o, 0.0));
    s += texture(u_shadow_map, v_light + vec3(-o, o, 0.0));
    s += texture(u_shadow_map, v_light + vec3(o, o, 0.0));
    f_color = vec4(mix(u_shadow_tint, vec3(1.0), s * 0.25), 1.0);
}
