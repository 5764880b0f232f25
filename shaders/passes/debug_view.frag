// debug_view.frag - what the viewer shows: the tone-mapped image, one G-buffer channel, or the
// error of the render against a reference, resampled (nearest) into the current viewport.
// Defines: VIEW_MODE (0 display, 1 G-buffer channel, 2 difference, 3 false-colour error, 4 a
// shadow map: its normalised depth as grey, 1 (nothing) white; a cube map's atlas of six faces).
// VIEW_MODE 1 includes "generated/debug_channel.glsl" (viewer/passes/debug_view.py), which defines
// vec3 debug_channel(GBuffer g): the chosen channel as display-ready [0, 1] values.
#include "lib/tonemap.glsl"

uniform ivec2 u_source_size;  // the render's size in pixels
in vec2 v_uv;                 // (0, 0) at the bottom-left of the viewport
layout(location = 0) out vec4 o_color;  // sRGB-encoded display values

#if VIEW_MODE == 0
uniform sampler2D u_display;
#elif VIEW_MODE == 4
uniform sampler2D u_shadow_map;  // a depth texture, its own size (not the render's)
#elif VIEW_MODE == 1
#define GBUFFER_READ
#include "generated/gbuffer.glsl"
#include "generated/debug_channel.glsl"
#else
uniform sampler2D u_radiance;
uniform sampler2D u_reference;
uniform float u_exposure;     // EV stops, as for the image
uniform float u_error_scale;  // relative error shown at the top of the colour map
#endif

// Turbo colour map, polynomial fit (Mikhailov 2019, "Turbo, an improved rainbow colormap"),
// t in [0, 1] -> sRGB-encoded colour.
vec3 turbo_srgb(float t) {
    const vec4 kr4 = vec4(0.13572138, 4.61539260, -42.66032258, 132.13108234);
    const vec4 kg4 = vec4(0.09140261, 2.19418839, 4.84296658, -14.18503333);
    const vec4 kb4 = vec4(0.10667330, 12.64194608, -60.58204836, 110.36276771);
    const vec2 kr2 = vec2(-152.94239396, 59.28637943);
    const vec2 kg2 = vec2(4.27729857, 2.82956604);
    const vec2 kb2 = vec2(-89.90310912, 27.34824973);
    t = clamp(t, 0.0, 1.0);
    vec4 v4 = vec4(1.0, t, t * t, t * t * t);
    vec2 v2 = v4.zw * v4.z;
    return vec3(dot(v4, kr4) + dot(v2, kr2), dot(v4, kg4) + dot(v2, kg2),
                dot(v4, kb4) + dot(v2, kb2));
}

void main() {
    ivec2 pixel = clamp(ivec2(v_uv * vec2(u_source_size)), ivec2(0), u_source_size - 1);
#if VIEW_MODE == 0
    o_color = vec4(texelFetch(u_display, pixel, 0).rgb, 1.0);
#elif VIEW_MODE == 4
    ivec2 map_size = textureSize(u_shadow_map, 0);
    ivec2 texel = clamp(ivec2(v_uv * vec2(map_size)), ivec2(0), map_size - 1);
    o_color = vec4(vec3(clamp(texelFetch(u_shadow_map, texel, 0).r, 0.0, 1.0)), 1.0);
#elif VIEW_MODE == 1
    o_color = vec4(debug_channel(gbuffer_load(pixel)), 1.0);
#else
    vec3 render = texelFetch(u_radiance, pixel, 0).rgb;
    vec3 reference = texelFetch(u_reference, pixel, 0).rgb;
#if VIEW_MODE == 2
    o_color = vec4(linear_to_srgb(clamp(apply_exposure(abs(render - reference), u_exposure),
                                        0.0, 1.0)), 1.0);
#else
    // relative error of the luminance-weighted colour; 1e-3 keeps black references finite
    vec3 w = vec3(0.2126, 0.7152, 0.0722);
    float rel = abs(dot(render - reference, w)) / max(dot(abs(reference), w), 1e-3);
    o_color = vec4(clamp(turbo_srgb(rel / u_error_scale), 0.0, 1.0), 1.0);
#endif
#endif
}
