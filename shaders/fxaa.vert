#version 330
// A screen rectangle (NDC) for the FXAA post-pass: the whole view.
uniform vec4 u_rect;   // x0, y0, x1, y1 in NDC
out vec2 v_uv;
void main() {
    vec2 c = vec2((gl_VertexID & 1) == 0 ? u_rect.x : u_rect.z, (gl_VertexID & 2) == 0 ? u_rect.y : u_rect.w);
    v_uv = c * 0.5 + 0.5;
    gl_Position = vec4(c, 0.0, 1.0);
}
