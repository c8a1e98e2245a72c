#version 330
// Flat ground (normal +Y), unshadowed here: the shadow is multiplied in by the
// receiver pass only where the shadow map reaches (receiver.frag).
uniform vec3 u_eye;
uniform vec3 u_light;        // linear irradiance on the ground (sun + sky + fill)
uniform vec3 u_haze_color;
uniform float u_haze_density;
in vec3 v_world;
in vec3 v_color;
out vec4 f_color;
void main() {
    vec3 c = v_color * u_light;
    c = (c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14);
    float keep = exp(-length(v_world - u_eye) * u_haze_density);
    f_color = vec4(mix(u_haze_color, sqrt(clamp(c, 0.0, 1.0)), keep), 1.0);
}
