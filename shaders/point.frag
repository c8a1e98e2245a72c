#version 330
in vec4 f_color;
in vec2 f_uv;
in float f_radius;
out vec4 o_color;
void main() {
    float d = length(f_uv);
    float cover = clamp(f_radius + 0.5 - d, 0.0, 1.0);
    // thin dark outline so points read on any background
    float edge = smoothstep(f_radius - 2.0, f_radius - 0.8, d);
    vec3 c = mix(f_color.rgb, f_color.rgb * 0.25, edge * step(3.0, f_radius));
    o_color = vec4(c, f_color.a * cover);
    if (o_color.a < 0.01) discard;
}
