#version 330
// Multiplied over the lit ground (blend DST_COLOR, ZERO) under the batsman: every caster
// stands above the ground, so a ground point is shadowed exactly where the sun's view
// of the casters is covered. One bilinear tap of that coverage (a ~1-texel soft edge)
// costs ~70% of four depth-compare taps on llvmpipe; four bilinear taps cost more.
uniform sampler2D u_coverage;
uniform vec3 u_shadow_tint;   // display-space ratio shadowed / lit ground
in vec3 v_light;
out vec4 f_color;
void main() {
    float covered = texture(u_coverage, v_light.xy).r;
    f_color = vec4(mix(vec3(1.0), u_shadow_tint, covered), 1.0);
}
