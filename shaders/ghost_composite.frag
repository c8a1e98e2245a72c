#version 330
// The cached translucent ghost (its nearest surface: colour, alpha and depth), blended
// over the scene where it is in front: the depth test compares gl_FragDepth with the scene.
uniform sampler2D u_ghost_color;
uniform sampler2D u_ghost_depth;
uniform ivec2 u_origin;    // the view's lower-left corner in the target
out vec4 f_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy) - u_origin;
    vec4 c = texelFetch(u_ghost_color, p, 0);
    if (c.a <= 0.0) discard;
    gl_FragDepth = texelFetch(u_ghost_depth, p, 0).r;
    f_color = c;
}
