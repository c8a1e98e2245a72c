#version 330
// Thick antialiased lines: each segment becomes a screen-space quad (with
// square caps of half the width so polylines join without gaps).
layout(lines) in;
layout(triangle_strip, max_vertices = 4) out;
uniform vec2 u_viewport;
in vec4 g_color[];
in float g_width[];
out vec4 f_color;
out float f_dist;   // signed pixels from the centre line
out float f_half;
void main() {
    vec4 a = gl_in[0].gl_Position, b = gl_in[1].gl_Position;
    const float eps = 0.01;
    if (a.w < eps && b.w < eps) return;
    if (a.w < eps) a = mix(a, b, (eps - a.w) / (b.w - a.w));
    if (b.w < eps) b = mix(b, a, (eps - b.w) / (a.w - b.w));
    vec2 half_vp = 0.5 * u_viewport;
    vec2 sa = a.xy / a.w * half_vp, sb = b.xy / b.w * half_vp;
    vec2 d = sb - sa;
    float len = length(d);
    d = len > 1e-4 ? d / len : vec2(1.0, 0.0);
    vec2 nrm = vec2(-d.y, d.x);
    float hw = 0.5 * max(g_width[0], 1.0) + 1.0;
    vec2 ext = d * (hw - 1.0);
    vec2 corners[4] = vec2[4](sa - ext + nrm * hw, sa - ext - nrm * hw, sb + ext + nrm * hw, sb + ext - nrm * hw);
    float side[4] = float[4](hw, -hw, hw, -hw);
    for (int i = 0; i < 4; i++) {
        vec4 base = (i < 2) ? a : b;
        f_color = (i < 2) ? g_color[0] : g_color[1];
        f_dist = side[i];
        f_half = hw - 1.0;
        gl_Position = vec4(corners[i] / half_vp * base.w, base.z, base.w);
        EmitVertex();
    }
    EndPrimitive();
}
