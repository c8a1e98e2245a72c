#version 330
uniform mat4 u_inv_view_proj;
uniform vec3 u_sun_dir;
uniform vec3 u_zenith;    // sRGB
uniform vec3 u_horizon;   // sRGB
in vec2 v_ndc;
out vec4 f_color;
void main() {
    vec4 a = u_inv_view_proj * vec4(v_ndc, -1.0, 1.0);
    vec4 b = u_inv_view_proj * vec4(v_ndc, 1.0, 1.0);
    vec3 d = normalize(b.xyz / b.w - a.xyz / a.w);
    float h = clamp(d.y, 0.0, 1.0);
    vec3 c = mix(u_horizon, u_zenith, pow(h, 0.55));
    float sun = max(dot(d, u_sun_dir), 0.0);
    c += vec3(1.0, 0.92, 0.75) * (0.25 * pow(sun, 12.0) + 0.6 * pow(sun, 600.0));
    f_color = vec4(min(c, vec3(1.0)), 1.0);
}
