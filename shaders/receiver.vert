#version 330
// Ground footprint of the shadow map: light-space coordinates are linear on the plane.
uniform mat4 u_view_proj;
uniform mat4 u_light_vp;
in vec3 in_pos;
out vec3 v_light;
void main() {
    v_light = (u_light_vp * vec4(in_pos + vec3(0.0, 1.0, 0.0), 1.0)).xyz * 0.5 + 0.5;
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
