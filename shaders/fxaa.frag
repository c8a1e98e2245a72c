#version 330
// FXAA (Lottes' "console" variant): blur along the local edge direction where luma
// contrast is high; one pass over the finished frame, 5 + 4 taps.
uniform sampler2D u_color;      // the frame, LINEAR filtered
uniform vec2 u_texel;           // 1 / size
in vec2 v_uv;
out vec4 f_color;
const vec3 LUMA = vec3(0.299, 0.587, 0.114);
void main() {
    vec3 rgbM = texture(u_color, v_uv).rgb;
    float lNW = dot(texture(u_color, v_uv + vec2(-0.5, -0.5) * u_texel).rgb, LUMA);
    float lNE = dot(texture(u_color, v_uv + vec2( 0.5, -0.5) * u_texel).rgb, LUMA);
    float lSW = dot(texture(u_color, v_uv + vec2(-0.5,  0.5) * u_texel).rgb, LUMA);
    float lSE = dot(texture(u_color, v_uv + vec2( 0.5,  0.5) * u_texel).rgb, LUMA);
    float lM = dot(rgbM, LUMA);
    float lMin = min(lM, min(min(lNW, lNE), min(lSW, lSE)));
    float lMax = max(lM, max(max(lNW, lNE), max(lSW, lSE)));
    if (lMax - lMin < max(0.05, lMax * 0.125)) {   // flat: keep the pixel
        f_color = vec4(rgbM, 1.0);
        return;
    }
    vec2 dir = vec2(-((lNW + lNE) - (lSW + lSE)), (lNW + lSW) - (lNE + lSE));
    float reduce = max((lNW + lNE + lSW + lSE) * 0.25 * 0.125, 1.0 / 128.0);
    float scale = 1.0 / (min(abs(dir.x), abs(dir.y)) + reduce);
    dir = clamp(dir * scale, -8.0, 8.0) * u_texel;
    vec3 a = 0.5 * (texture(u_color, v_uv - dir / 6.0).rgb + texture(u_color, v_uv + dir / 6.0).rgb);
    vec3 b = 0.5 * a + 0.25 * (texture(u_color, v_uv - dir * 0.5).rgb + texture(u_color, v_uv + dir * 0.5).rgb);
    float lB = dot(b, LUMA);
    f_color = vec4((lB < lMin || lB > lMax) ? a : b, 1.0);
}
