// Shared lighting: sun (key, casts the shadow) + fill + hemisphere ambient + a little rim,
// an ACES-style tone curve, gamma 2 and haze toward the horizon colour.
// llvmpipe is the target: no vec3 pow per pixel (colours are linearised per vertex),
// one hardware-PCF shadow tap on shaded objects (coordinates from the vertex shader).
uniform vec3 u_eye;
uniform vec3 u_sun_dir;        // unit, towards the sun
uniform vec3 u_sun_color;
uniform vec3 u_fill_dir;       // unit, towards the fill light
uniform vec3 u_fill_color;
uniform vec3 u_sky_ambient;
uniform vec3 u_ground_ambient;
uniform vec3 u_haze_color;     // display colour of the sky at the horizon (applied after the tone curve)
uniform sampler2DShadow u_shadow_map;
uniform float u_shadow_on;

// shade() in two parts: returns what the sun's shadow scales, ``rest`` what it does not.
vec3 shade_split(vec3 albedo, vec3 n, vec3 world_pos, float gloss, out vec3 rest) {
    vec3 v = normalize(u_eye - world_pos);
    float ndl = max(dot(n, u_sun_dir), 0.0);
    float fill = max(dot(n, u_fill_dir), 0.0);
    vec3 ambient = mix(u_ground_ambient, u_sky_ambient, 0.5 + 0.5 * n.y);
    vec3 h = normalize(u_sun_dir + v);
    float spec_pow = mix(6.0, 120.0, gloss * gloss);
    float spec = pow(max(dot(n, h), 0.0), spec_pow) * (0.04 + 0.5 * gloss) * (spec_pow + 8.0) / 25.0;
    float r = 1.0 - max(dot(n, v), 0.0);
    float rim = r * r * r * (0.35 + 0.65 * max(n.y, 0.0));
    rest = albedo * (ambient + u_fill_color * fill) + rim * 0.22 * u_sky_ambient * (0.5 + albedo);
    return u_sun_color * ndl * (albedo + spec);
}

vec3 shade(vec3 albedo, vec3 n, vec3 world_pos, float gloss, float shadow) {
    vec3 rest;
    vec3 sun = shade_split(albedo, n, world_pos, gloss, rest);
    return rest + sun * shadow;
}

vec3 tone(vec3 c) {
    c = (c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14);
    return sqrt(clamp(c, 0.0, 1.0));
}
