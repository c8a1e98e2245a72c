#version 330
// The tiles of the cached ghost layer that hold any of the ghost (NDC, built from its alpha
// once after the layer is drawn): the composite shades only those, not its whole box.
in vec2 in_pos;
void main() {
    gl_Position = vec4(in_pos, 0.0, 1.0);
}
