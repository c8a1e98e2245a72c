#version 330
in vec4 f_color;
in float f_dist;
in float f_half;
out vec4 o_color;
void main() {
    float cover = clamp(f_half + 0.5 - abs(f_dist), 0.0, 1.0);
    o_color = vec4(f_color.rgb, f_color.a * cover);
    if (o_color.a < 0.01) discard;
}
