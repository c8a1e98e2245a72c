// Haze: fraction of the surface colour left at a distance (exp falloff), for vertex shaders.
uniform float u_haze_density;  // per cm
float haze_keep(vec3 world_pos, vec3 eye) { return exp(-length(world_pos - eye) * u_haze_density); }
vec3 srgb_to_linear(vec3 c) { return pow(max(c, vec3(0.0)), vec3(2.2)); }
