#version 330
// Depth only (shadow maps, ghost pre-pass); where a coverage target is attached
// (the batsman's shadow map) it marks the texels a caster covers.
out vec4 f_color;
void main() { f_color = vec4(1.0); }
