// shade_path.frag - `path`: a progressive path tracer with our BSDF (the one ggx_mc integrates
// and relight reference traces: Cook-Torrance GGX + Lambert scaled by 1 - E_spec(n.v), optional
// multiple-scattering compensation). The first hit is the G-buffer's (the rasteriser's surface,
// normal maps and textures included); every later vertex is a ray against the scene's triangles
// (passes/raytrace.glsl). At each vertex: next-event estimation of the environment (importance
// sampled, MIS against the BSDF with the power heuristic), of every punctual light (a shadow ray;
// a directional light of finite angular size as a uniform disc, sampled over its cone), then a
// BSDF-sampled continuation; a continuation that escapes picks up the environment with the
// complementary MIS weight; one that hits an emissive surface picks up its emission. Paths have
// at most u_max_depth segments counted as Mitsuba counts them (2: direct light only), with
// Russian roulette after three bounces. Writes the mean of samples u_sample_start ..
// + u_sample_count - 1 (passes/accumulate.frag averages batches).
// Transmission (GBUFFER_HAS_TRANSMISSION, KHR_materials_transmission / _volume): a transmissive
// surface is seen from both sides; a vertex on a volume's back face is inside it (eta inverted)
// and the segment that reached it is attenuated by Beer-Lambert (the volume's sigma over the
// segment's length: a volume holds nothing else). Shadow rays treat every surface, transmissive
// or not, as a blocker, as the reference's (Mitsuba's path integrator): light through glass is
// found by the BSDF's continuation from the glass's own vertices, each MIS-weighted against
// that vertex's own light sampling. A dispersive volume (GBUFFER_HAS_DISPERSION) refracts
// each colour channel by its own IOR (passes/surface_mc.glsl surface_set_dispersion).
// Defines: MULTISCATTER, BACKGROUND_ENVIRONMENT, LIGHT_COUNT, LIGHT_POSITIONAL, RAYTRACED.
#define RAYTRACED 1
#include "passes/deferred.glsl"
#include "lib/brdf.glsl"
#include "lib/ibl.glsl"
#include "lib/shading.glsl"
#include "passes/lights.glsl"
#include "lib/sampling.glsl"
#include "lib/mc.glsl"
#include "lib/env_sampling.glsl"
#include "lib/path.glsl"
#include "passes/surface_mc.glsl"
#include "passes/anisotropy_lights.glsl"
#include "passes/raytrace.glsl"

uniform sampler2D u_env_marginal;
uniform sampler2D u_env_conditional;
uniform sampler2D u_env_pdf;
uniform uint u_sample_start;
uniform uint u_sample_count;
uniform uint u_seed;
uniform int u_max_depth;  // path segments, the camera's included (Mitsuba's max_depth)
#if LIGHT_COUNT > 0
uniform float u_light_angular_radius[LIGHT_COUNT];  // directional lights' disc (radians), else 0
#endif

#define DIMS_PER_BOUNCE 4u  // 2D sample pairs a bounce draws: environment, lights, BSDF, roulette

// A vertex of a path: where it is, the geometric normal on the side the path arrived from (the
// side rays leave from), and the BRDF there (passes/surface_mc.glsl).
struct PathVertex {
    vec3 p;
    vec3 ng;
    Surface s;
};

PathVertex path_vertex(vec3 p, vec3 ng, vec3 n, vec3 v, vec3 albedo, float roughness,
                       float metallic, float specular, vec4 dielectric, vec2 coat, vec3 n_coat,
                       vec4 sheen) {
    vec2 dfg;
    vec4 fresnel = surface_f0_f90(albedo, metallic, specular, dielectric);
    return PathVertex(p, ng, surface_init(n, v, albedo, roughness, metallic, fresnel.rgb,
                                          fresnel.a, coat, n_coat, sheen, dfg));
}

vec3 path_env_radiance(vec3 l) {
    return textureLod(u_env_radiance, equirect_uv(env_dir(l)), 0.0).rgb * u_env_intensity;
}

// Is the segment from s along l (unit) clear up to distance t_max?
bool path_visible(PathVertex s, vec3 l, float t_max) {
    vec3 o = ray_offset(s.p, s.ng, l);
    return !bvh_any_hit(o, l, t_max);
}

// Next-event estimation of the environment at s: one importance-sampled direction, MIS-weighted
// against the BSDF's pdf.
vec3 path_environment(PathVertex s, vec2 u) {
    vec4 e = sample_env(u_env_marginal, u_env_conditional, u_env_pdf, u);
    if (!(e.w > 0.0)) return vec3(0.0);
    vec3 l = rotate_y(e.xyz, u_env_rotation);
    vec3 f = surface_brdf_cos(s.s, l);
    if (all(equal(f, vec3(0.0)))) return vec3(0.0);
    if (!path_visible(s, l, 3.0e38)) return vec3(0.0);
    float w = mis_weight(e.w, surface_brdf_pdf(s.s, l), 2.0);
    return path_env_radiance(l) * f * (w / e.w);
}

// Next-event estimation of the punctual lights at s, each with a shadow ray.
vec3 path_lights(PathVertex s, vec2 u) {
    vec3 c = vec3(0.0);
#if LIGHT_COUNT > 0
    for (int i = 0; i < LIGHT_COUNT; ++i) {
        vec4 la = punctual_light(u_light_type[i], u_light_position[i], u_light_direction[i],
                                 u_light_cone_range[i], s.p);
        if (!(la.w > 0.0)) continue;
        vec3 l = la.xyz;
        float t_max = 3.0e38;
        float scale = la.w;
        if (u_light_type[i] == LIGHT_TYPE_DIRECTIONAL) {
            float radius = u_light_angular_radius[i];
            if (radius > 0.0) {  // a uniform disc: E / (pi sin^2) over the cone, / its pdf
                float cos_max = cos(radius);
                l = tangent_to_world(sample_uniform_cone(u, cos_max), la.xyz);
                float s2 = sq(sin(radius));
                scale = (1.0 / (PI * s2)) / pdf_uniform_cone(cos_max);
            }
        } else {
            t_max = length(u_light_position[i] - s.p) * (1.0 - 1.0e-4);
        }
        vec3 f = surface_brdf_cos(s.s, l);
        if (all(equal(f, vec3(0.0)))) continue;
        if (path_visible(s, l, t_max)) c += f * u_light_intensity[i] * scale;
    }
#endif
    return c;
}

// One path's radiance from the G-buffer's surface s0 (its own emission excluded: added once).
vec3 trace_path(PathVertex s0, uvec2 pixel, uint index) {
    vec3 radiance = vec3(0.0);
    vec3 beta = vec3(1.0);
    PathVertex s = s0;
    for (int bounce = 0; bounce + 2 <= u_max_depth; ++bounce) {
        // a shading normal facing away from where the path came from: no light leaves it
        // towards that side (as the reference's BSDF evaluates)
        if (!(s.s.NoV > 0.0)) break;
#if GBUFFER_HAS_DISPERSION
        surface_weight_channels(s.s, beta);  // a dispersive BTDF's channel draw (surface_mc.glsl)
#endif
        uint dim = uint(bounce) * DIMS_PER_BOUNCE;
        radiance += beta * path_environment(s, mc_sample_2d(pixel.x, pixel.y, index, u_seed, dim));
        radiance += beta * path_lights(s, mc_sample_2d(pixel.x, pixel.y, index, u_seed, dim + 1u));
        // the last segment (Mitsuba's max_depth): its BSDF-sampled ray still meets what it
        // meets - the environment, MIS-weighted against the sampling above, or an emitter - and
        // the path ends there (without it the last bounce kept only the light-sampled half of
        // its MIS pair and came out dark: depth 6 matched the reference at depth 5 through glass)
        bool last = bounce + 3 > u_max_depth;
        vec3 l = sample_surface_brdf(s.s, mc_sample_2d(pixel.x, pixel.y, index, u_seed, dim + 2u));
        float pdf = surface_brdf_pdf(s.s, l);
        vec3 f = surface_brdf_cos(s.s, l);
        if (!(pdf > 0.0) || all(equal(f, vec3(0.0)))) break;
        beta *= f / pdf;
        vec3 o = ray_offset(s.p, s.ng, l);
        RayHit hit = bvh_closest_hit(o, l, 3.0e38);
        if (hit.triangle < 0) {  // escaped: the environment, weighted against its own sampling
            float w = mis_weight(pdf, env_pdf(u_env_pdf, env_dir(l)), 2.0);
            radiance += beta * path_env_radiance(l) * w;
            break;
        }
        TracedSurface t = rt_surface(hit, o, l);
        bool front = dot(t.ng, l) < 0.0;
        bool see_through = t.transmission.x > 0.0;  // both sides, whatever its doubleSided
        if (!front && !t.double_sided && !see_through) break;  // a single-sided back: black
        vec3 ng = front ? t.ng : -t.ng;
        vec3 n = front ? t.n : -t.n;
#if GBUFFER_HAS_TRANSMISSION
        if (!front && see_through && t.transmission.y > 0.0) {  // the segment inside a volume
            beta *= volume_attenuation(t.sigma, hit.t);
        }
#endif
        radiance += beta * t.emission;  // emissive surfaces are found, not sampled
        if (last) break;
        s = path_vertex(t.p, ng, n, -l, t.albedo, t.roughness, t.metallic, t.specular,
                        t.dielectric, t.clearcoat, n, TRACED_SHEEN(t));
#ifdef TRACED_IRIDESCENCE_FIELD
        // the thin film, as at the first hit (before the transmission's split)
        surface_set_iridescence(s.s, t.iridescence, t.clearcoat.x,
                                diffuse_color(t.albedo, t.metallic),
                                ibl_dfg(u_env_dfg, s.s.NoV,
                                        clamp_perceptual_roughness(t.roughness)));
#endif
#if GBUFFER_HAS_TRANSMISSION
        surface_set_transmission(s.s, t.transmission.x, t.transmission.y, !front);
#endif
#ifdef TRACED_DISPERSION_FIELD
        surface_set_dispersion(s.s, t.transmission.y, t.dispersion, !front);
#endif
#ifdef TRACED_ANISOTROPY_FIELD
        surface_set_anisotropy(s.s, t.anisotropy.xyz, t.anisotropy.w);
#endif
        float q = path_continue_probability(beta, float(bounce + 1));
        if (mc_sample_2d(pixel.x, pixel.y, index, u_seed, dim + 3u).x >= q) break;
        beta /= q;
    }
    bool finite = !any(isnan(radiance)) && !any(isinf(radiance));
    return finite ? radiance : vec3(0.0);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
    vec3 d = view_ray_ws(gl_FragCoord.xy);
    vec3 background = background_radiance(d);
    if (g.alpha <= 0.0) {
        write_radiance(vec3(0.0), background, 0.0);
        return;
    }
    vec3 v = -d;
    vec3 n = shading_normal(g.normal, v);
    vec3 p = light_surface_position(gl_FragCoord.xy, g.depth);
    // the G-buffer holds no geometric normal: the shading normal stands in for the ray offset
    PathVertex s0 = path_vertex(p, n, n, v, g.albedo, g.roughness, g.metallic, g.specular,
                                  g.dielectric, g.clearcoat.xy,
                                  shading_normal(oct_decode(g.clearcoat.zw), v),
                                  GBUFFER_SHEEN(g));
#if GBUFFER_HAS_ANISOTROPY
    // KHR_materials_anisotropy at the first hit (traced hits: raytrace.glsl rt_anisotropy)
    vec4 aniso = anisotropy_at(GBUFFER_ANISOTROPY(g), g.normal, s0.s.n);
    surface_set_anisotropy(s0.s, aniso.xyz, aniso.w);
#endif
#if GBUFFER_HAS_IRIDESCENCE
    // the thin film at the first hit (traced hits: trace_path, the same)
    surface_set_iridescence(s0.s, g.iridescence, g.clearcoat.x,
                            diffuse_color(g.albedo, g.metallic),
                            ibl_dfg(u_env_dfg, s0.s.NoV, clamp_perceptual_roughness(g.roughness)));
#endif
#if GBUFFER_HAS_TRANSMISSION
    // the first hit is seen from outside (a camera inside a volume is not modelled)
    surface_set_transmission(s0.s, g.transmission, g.transmission_ior, false);
#if GBUFFER_HAS_DISPERSION
    surface_set_dispersion(s0.s, g.transmission_ior, g.dispersion, false);
#endif
#endif
    vec3 sum = vec3(0.0);
    for (uint k = 0u; k < u_sample_count; ++k) {
        sum += trace_path(s0, uvec2(pixel), u_sample_start + k);
    }
    vec3 c = sum / float(max(u_sample_count, 1u));
    write_radiance(c + emitted_radiance(g), background, g.alpha);
}
