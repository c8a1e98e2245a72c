#version 330
// Round points of a size in pixels: a screen-space quad per point.
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;
uniform vec2 u_viewport;
in vec4 g_color[];
in float g_width[];
out vec4 f_color;
out vec2 f_uv;
out float f_radius;
void main() {
    vec4 p = gl_in[0].gl_Position;
    if (p.w <= 0.01) return;
    float r = 0.5 * max(g_width[0], 1.0) + 1.0;
    vec2 px = vec2(2.0) / u_viewport * p.w;
    for (int i = 0; i < 4; i++) {
        vec2 c = vec2((i & 1) == 0 ? -1.0 : 1.0, (i & 2) == 0 ? -1.0 : 1.0);
        f_color = g_color[0];
        f_uv = c * r;
        f_radius = r - 1.0;
        gl_Position = vec4(p.xy + c * r * px, p.z - 0.0005 * p.w, p.w);
        EmitVertex();
    }
    EndPrimitive();
}
