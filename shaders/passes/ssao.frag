// ssao.frag - screen-space ambient occlusion and one-bounce indirect light from the G-buffer
// (thesis sec. 6.4, eqs. 6.19-6.22). For every covered pixel, u_rays cosine-weighted directions
// around the normal are marched in view space in u_steps steps up to u_radius (world units); a
// step is a hit when its depth lies behind the stored surface depth by less than u_thickness
// (eq. 6.20, lib/ssao.glsl). With cosine sampling, eq. 6.19 is estimated by
//   O(x) = 1 - (1/R) sum_k V_k.
// SSAO_INDIRECT = 0 writes O to all four channels (read by passes/deferred.glsl's
// ambient_occlusion). SSAO_INDIRECT = 1 marches the same rays and adds eq. 6.22 to u_direct
// (the lighting pass's output, L_dir of eq. 6.18): the radiance arriving along a ray that hits
// pixel p is approximated by the direct radiance stored at p (eq. 6.21; exact for diffuse hit
// points), so L_ind = (1 - m) a (1/R) sum_k V_k L_dir(p_k).
// Directions and step offsets come from lib/mc.glsl's sequence (dimension pairs 2, 3) for u_seed.
// Defines: SSAO_INDIRECT (0/1). Twin: learned.twins.ssao.ssao_pass.
#include "passes/deferred.glsl"
#include "lib/shading.glsl"
#include "lib/sampling.glsl"
#include "lib/mc.glsl"
#include "lib/ssao.glsl"

uniform int u_rays;
uniform int u_steps;
uniform float u_radius;     // world units
uniform float u_thickness;  // delta of eq. 6.20, world units
uniform uint u_seed;
#if SSAO_INDIRECT
uniform sampler2D u_direct;
#endif

vec3 to_view(vec3 w) {
    return transpose(u_camera_to_world) * w;
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
#if SSAO_INDIRECT
    vec4 direct = texelFetch(u_direct, pixel, 0);
#endif
    if (g.alpha <= 0.0 || !(g.depth > 0.0)) {
#if SSAO_INDIRECT
        o_radiance = direct;
#else
        o_radiance = vec4(1.0);
#endif
        return;
    }
    vec3 d = view_ray_ws(gl_FragCoord.xy);
    vec3 n_vs = to_view(shading_normal(g.normal, -d));
    vec3 p_vs = view_position(gl_FragCoord.xy, u_resolution, g.depth, u_tan_half_fov);
    float hits = 0.0;
    vec3 gathered = vec3(0.0);
    for (int k = 0; k < u_rays; ++k) {
        vec2 u = mc_sample_2d(uint(pixel.x), uint(pixel.y), uint(k), u_seed, 2u);
        float jitter = 1.0 - mc_sample_2d(uint(pixel.x), uint(pixel.y), uint(k), u_seed, 3u).x;
        vec3 w = tangent_to_world(sample_cosine_hemisphere(u), n_vs);
        for (int j = 0; j < u_steps; ++j) {
            vec3 q = p_vs + w * (u_radius * (float(j) + jitter) / float(u_steps));
            vec3 f = view_to_frag(q, u_resolution, u_tan_half_fov);
            if (!(f.z > 0.0) || any(lessThan(f.xy, vec2(0.0))) || any(greaterThanEqual(f.xy, u_resolution))) {
                break;  // behind the camera or off screen: nothing known occludes
            }
            ivec2 hp = ivec2(floor(f.xy));
            GBuffer h = gbuffer_load(hp);
            if (h.alpha <= 0.0) continue;
            vec3 hp_vs = view_position(vec2(hp) + 0.5, u_resolution, h.depth, u_tan_half_fov);
            vec3 hn = h.normal;
            vec3 hn_vs = dot(hn, hn) > 1e-12 ? to_view(normalize(hn)) : vec3(0.0);
            float z_d = surface_depth_at(q, hp_vs, hn_vs, h.depth);
            if (ssao_occluded(f.z, z_d, u_thickness) > 0.5) {
                hits += 1.0;
#if SSAO_INDIRECT
                gathered += texelFetch(u_direct, hp, 0).rgb;
#endif
                break;
            }
        }
    }
    float rays = float(max(u_rays, 1));
#if SSAO_INDIRECT
    vec3 indirect = (1.0 - saturate(g.metallic)) * g.albedo * gathered / rays;
    bool finite = !any(isnan(indirect)) && !any(isinf(indirect));
    o_radiance = vec4(direct.rgb + (finite ? indirect * g.alpha : vec3(0.0)), direct.a);
#else
    o_radiance = vec4(1.0 - hits / rays);
#endif
}
