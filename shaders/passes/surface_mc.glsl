// surface_mc.glsl (pass chunk) - the BRDF the Monte-Carlo passes integrate (ggx_mc's and the
// path tracer's: Cook-Torrance GGX + Lambert scaled by 1 - E_spec(n.v), optional
// multiple-scattering compensation) at one surface: its evaluation f cos, the pdf of its lobe
// mixture and a draw from it. Included by passes/shade_ggx_mc.frag and passes/shade_path.frag
// after lib/ibl.glsl, lib/shading.glsl, lib/sampling.glsl and lib/mc.glsl; reads u_env_dfg.
// Twin: learned.twins.shade_ggx_mc (the ggx_mc pass; scenes without a coat).
// With GBUFFER_HAS_CLEARCOAT (a scene with KHR_materials_clearcoat), the coat of lib/layers.glsl
// is layered over this BRDF: (1 - w) f_base + w D_c V_c on the coat's normal, and drawn as a third
// lobe by its albedo w dfg_c.y; compiled out otherwise. With GBUFFER_HAS_SHEEN (a scene with
// KHR_materials_sheen), the sheen of lib/layers.glsl lies between them: f_sheen + (1 - max3(C)
// max(E(n.v), E(|n.l|))) f_base (the spec's albedo scaling, exact here; the base's BTDF below
// is scaled by it too), drawn uniformly over the hemisphere by its albedo max3(C) E(n.v) against
// the base's (transmission included).
// With GBUFFER_HAS_IRIDESCENCE (KHR_materials_iridescence), the base's specular Fresnel is the
// spec's mix with the thin film's (lib/iridescence.glsl iridescence_fresnel_mix) at each half
// vector, exactly; the diffuse keeps 1 - E_spec(n.v), E_spec the DFG terms' plus what the film
// changes (iridescence_albedo_delta): surface_set_iridescence. Under a coat the film is seen
// from the coat's IOR (iridescence_outside_ior of the coat factor; 1 in a scene without a coat).
// With GBUFFER_HAS_TRANSMISSION (KHR_materials_transmission / _volume), the base's non-specular
// part is split by the factor T (surface_set_transmission): (1 - T) stays Lambertian, T becomes
// lib/transmission.glsl's BTDF below the surface (thin-walled, or refracting with eta), drawn as
// a lobe of its own; each lobe's draws outside its own hemisphere are rejected (the density of
// every direction is then the mixture's, above and below).
// With GBUFFER_HAS_ANISOTROPY (KHR_materials_anisotropy), surface_set_anisotropy makes the
// specular lobe the anisotropic GGX of lib/anisotropy.glsl (alpha_t along the direction t,
// alpha_b = the material's across it): evaluated, and drawn by its anisotropic visible normals;
// the energy split (1 - E_spec) and the lobe choice keep the isotropic lobe's albedo of alpha_b,
// and the transmission lobe stays isotropic.
// With GBUFFER_HAS_DISPERSION (KHR_materials_dispersion), a dispersive volume's BTDF refracts each
// colour channel by its own eta (surface_set_dispersion, surface_btdf_cos_rgb).
#include "lib/transmission.glsl"
#include "lib/anisotropy.glsl"
#include "lib/iridescence.glsl"
#ifndef MULTISCATTER
#define MULTISCATTER 0
#endif

uniform sampler2D u_env_dfg;

struct Surface {
    vec3 n;            // shading normal, world space
    vec3 t;            // tangent frame (tangent_to_world's)
    vec3 b;
    vec3 v;            // towards the viewer
    float NoV;
    vec3 diffuse;      // diffuse colour x ambient occlusion x (1 - E_spec)
    vec3 f0;
    float f90;
    float a;           // alpha = clamped perceptual roughness^2
    vec3 spec_scale;   // multiple-scattering energy compensation (1 without)
    float p_spec;      // probability of sampling the specular lobe ("brdf", "mis")
#if GBUFFER_HAS_ANISOTROPY
    vec2 alphas;       // (alpha_t along t, alpha_b along b); alpha_t = alpha_b: isotropic
#endif
#if GBUFFER_HAS_CLEARCOAT
    vec3 n_c;          // the coat's normal (lib/layers.glsl), its tangent frame
    vec3 t_c;
    vec3 b_c;
    float NoV_c;
    float w_c;         // clearcoat_weight: 0 without a coat
    float a_c;         // the coat's alpha
    float p_coat;      // probability of sampling the coat (before the base's two lobes)
#endif
#if GBUFFER_HAS_TRANSMISSION
    vec3 transmit;     // the BTDF's colour: diffuse's share T (diffuse keeps 1 - T)
    float eta;         // eta_l / eta_v of the volume's refraction; 0 = thin-walled
    float p_trans;     // probability of the BTDF among the base's non-specular lobes (T)
#if GBUFFER_HAS_DISPERSION
    vec3 etas;         // eta per colour channel (each s.eta without dispersion)
    vec3 channel_w;    // the probabilities of drawing each channel's refraction (sum 1)
#endif
#endif
#if GBUFFER_HAS_SHEEN
    vec3 sheen;        // KHR_materials_sheen colour (0: none) on the base's normal
    float r_sheen;     // its roughness
    float e_sheen;     // E(n.v, r_sheen), lib/layers.glsl sheen_albedo
    float p_sheen;     // probability of sampling it (after the coat, before the base's lobes)
#endif
#if GBUFFER_HAS_IRIDESCENCE
    vec3 film;         // KHR_materials_iridescence: factor, thickness (nm), IOR; x = 0: none
    float film_outside;  // the IOR the film is seen from: 1 (air), 1.5 under a full coat
#endif
};

#if GBUFFER_HAS_TRANSMISSION
// The BTDF times |n.l| (no colour) and its density for l below the surface.
float surface_btdf_cos(Surface s, vec3 l) {
    return s.eta > 0.0 ? rough_refraction_cos(s.a, s.eta, s.n, s.v, l)
                       : thin_transmission_cos(s.a, s.n, s.v, l);
}

float surface_btdf_pdf(Surface s, vec3 l) {
    if (s.eta > 0.0) return rough_refraction_pdf(s.a, s.eta, s.n, s.v, l);
    if (!(-dot(s.n, l) > 0.0)) return 0.0;
    vec3 h = half_vector(s.v, mirror_through(s.n, l));
    return pdf_ggx_vndf(s.NoV, saturate(dot(s.n, h)), s.a);
}

// The transmission of a surface_init surface: factor T, the volume's IOR (0: thin-walled),
// inside: whether v is inside the volume (the hit is the mesh's back face).
void surface_set_transmission(inout Surface s, float T, float ior, bool inside) {
    T = saturate(T);
    s.transmit = s.diffuse * T;
    s.diffuse *= 1.0 - T;
    s.eta = ior > 0.0 ? (inside ? 1.0 / ior : ior) : 0.0;
    s.p_trans = T;
#if GBUFFER_HAS_DISPERSION
    s.etas = vec3(s.eta);
    s.channel_w = vec3(1.0 / 3.0);
#endif
}

#if GBUFFER_HAS_DISPERSION
#include "passes/surface_dispersion.glsl"
#endif
#endif

#if GBUFFER_HAS_IRIDESCENCE
// The thin film (factor, thickness nm, IOR) of a surface_init surface whose diffuse colour
// before the energy split is `diffuse` and whose DFG terms are dfg: the Fresnel of its specular
// lobe becomes the film's mix (surface_base_brdf_cos), the diffuse keeps 1 - E_spec(n.v) of
// the film's lobe (the DFG terms' plus iridescence_albedo_delta; the multiple-scattering
// compensation stays the base's), and the specular lobe is drawn by the film's Fresnel at n.v.
// `coat`: the surface's clearcoat factor (0: none): the film is seen from the coat's IOR
// (iridescence_outside_ior; the spec evaluates the coat before the film), from air in a scene
// without a coat. Before surface_set_transmission and the occlusion.
void surface_set_iridescence(inout Surface s, vec3 film, float coat, vec3 diffuse, vec2 dfg) {
    s.film = film;
#if GBUFFER_HAS_CLEARCOAT
    s.film_outside = iridescence_outside_ior(coat);
#else
    s.film_outside = 1.0;
#endif
    if (!(film.x > 0.0 && film.y > 0.0)) return;
    vec3 e_spec = (ibl_specular_dfg(dfg, s.f0, s.f90)
                   + iridescence_albedo_delta(s.f0, s.f90, s.NoV, s.a, film, s.film_outside))
                  * s.spec_scale;
    s.diffuse = diffuse * max(1.0 - e_spec, 0.0);
    s.p_spec = specular_lobe_probability(s.diffuse,
                                         iridescence_f0(s.f0, s.f90, s.NoV, film, s.film_outside),
                                         s.f90, s.NoV);
}
#endif

#if GBUFFER_HAS_ANISOTROPY
// KHR_materials_anisotropy of strength s along the unit direction t (in n's plane) on a
// surface_init surface: the frame (t, b) becomes the lobe's, alpha_t grows with s.
void surface_set_anisotropy(inout Surface s, vec3 t, float strength) {
    s.alphas = anisotropy_alphas(s.a, strength);
    if (s.alphas.x > s.alphas.y) {
        s.t = t;
        s.b = cross(s.n, t);
    }
}

// Whether the surface's specular lobe is anisotropic.
bool surface_anisotropic(Surface s) {
    return s.alphas.x > s.alphas.y;
}
#endif

// The specular lobe's Fresnel at v.h: the thin film's mix where the scene has one
// (surface_set_iridescence), else Schlick's.
vec3 surface_fresnel(Surface s, float VoH) {
#if GBUFFER_HAS_IRIDESCENCE
    return iridescence_fresnel_mix(s.f0, s.f90, VoH, s.film, s.film_outside);
#else
    return f_schlick(s.f0, s.f90, VoH);
#endif
}

// The specular BRDF (no n.l, no compensation) for l with half vector h.
vec3 surface_specular_brdf(Surface s, vec3 l, vec3 h, float NoL, float NoH, float VoH) {
#if GBUFFER_HAS_ANISOTROPY
    if (surface_anisotropic(s)) {
        return d_ggx_anisotropic(NoH, dot(s.t, h), dot(s.b, h), s.alphas.x, s.alphas.y)
               * v_smith_ggx_correlated_anisotropic(s.NoV, NoL, dot(s.t, s.v), dot(s.b, s.v),
                                                    dot(s.t, l), dot(s.b, l), s.alphas.x,
                                                    s.alphas.y)
               * surface_fresnel(s, VoH);
    }
#endif
#if GBUFFER_HAS_IRIDESCENCE
    return d_ggx(NoH, s.a) * v_smith_ggx_correlated(s.NoV, NoL, s.a) * surface_fresnel(s, VoH);
#else
    return ggx_specular_brdf(s.f0, s.f90, s.NoV, NoL, NoH, VoH, s.a);
#endif
}

// pdf of the specular lobe's visible-normal draw of l (half vector h).
float surface_specular_pdf(Surface s, vec3 h, float NoH) {
#if GBUFFER_HAS_ANISOTROPY
    if (surface_anisotropic(s)) {
        return pdf_ggx_vndf_anisotropic(vec3(dot(s.v, s.t), dot(s.v, s.b), s.NoV),
                                        vec3(dot(h, s.t), dot(h, s.b), NoH), s.alphas.x,
                                        s.alphas.y);
    }
#endif
    return pdf_ggx_vndf(s.NoV, NoH, s.a);
}

// f(v, l) (n.l), 0 below the surface.
vec3 surface_base_brdf_cos(Surface s, vec3 l) {
    float NoL = dot(s.n, l);
#if GBUFFER_HAS_DISPERSION
    if (!(NoL > 0.0) && s.p_trans > 0.0) return s.transmit * surface_btdf_cos_rgb(s, l);
#elif GBUFFER_HAS_TRANSMISSION
    if (!(NoL > 0.0) && s.p_trans > 0.0) return s.transmit * surface_btdf_cos(s, l);
#endif
    if (!(NoL > 0.0)) return vec3(0.0);
    vec3 h = normalize(s.v + l);
    float NoH = saturate(dot(s.n, h));
    float VoH = saturate(dot(s.v, h));
    vec3 spec = surface_specular_brdf(s, l, h, NoL, NoH, VoH) * s.spec_scale;
    return (s.diffuse * INV_PI + spec) * NoL;
}

vec3 surface_brdf_cos(Surface s, vec3 l) {
    vec3 f = surface_base_brdf_cos(s, l);
#if GBUFFER_HAS_SHEEN
    if (s.e_sheen > 0.0) {
        f = f * sheen_scaling(s.sheen, s.e_sheen, sheen_albedo(abs(dot(s.n, l)), s.r_sheen))
            + sheen_light(s.sheen, s.r_sheen, s.n, s.v, l);
    }
#endif
#if GBUFFER_HAS_CLEARCOAT
    f = f * (1.0 - s.w_c) + vec3(clearcoat_light(s.w_c, s.a_c, s.n_c, s.v, l));
#endif
    return f;
}

// pdf of "brdf" sampling (lobe mixture: VNDF-reflected specular, cosine diffuse) for l.
float surface_base_brdf_pdf(Surface s, vec3 l) {
    float NoL = dot(s.n, l);
    float p_diffuse = 1.0 - s.p_spec;
#if GBUFFER_HAS_TRANSMISSION
#if GBUFFER_HAS_DISPERSION
    if (!(NoL > 0.0) && s.p_trans > 0.0) return p_diffuse * s.p_trans * surface_btdf_pdf_rgb(s, l);
#else
    if (!(NoL > 0.0) && s.p_trans > 0.0) return p_diffuse * s.p_trans * surface_btdf_pdf(s, l);
#endif
    p_diffuse *= 1.0 - s.p_trans;
#endif
    if (!(NoL > 0.0)) return 0.0;
    vec3 h = normalize(s.v + l);
    float NoH = saturate(dot(s.n, h));
    return s.p_spec * surface_specular_pdf(s, h, NoH) + p_diffuse * pdf_cosine_hemisphere(NoL);
}

float surface_brdf_pdf(Surface s, vec3 l) {
    float p = surface_base_brdf_pdf(s, l);
#if GBUFFER_HAS_SHEEN
    p = s.p_sheen * (dot(s.n, l) > 0.0 ? 0.5 * INV_PI : 0.0) + (1.0 - s.p_sheen) * p;
#endif
#if GBUFFER_HAS_CLEARCOAT
    float p_coat = 0.0;
    if (dot(s.n_c, l) > 0.0) {
        p_coat = pdf_ggx_vndf(s.NoV_c, saturate(dot(s.n_c, normalize(s.v + l))), s.a_c);
    }
    p = s.p_coat * p_coat + (1.0 - s.p_coat) * p;
#endif
    return p;
}

vec3 sample_surface_brdf(Surface s, vec2 u) {
#if GBUFFER_HAS_CLEARCOAT
    if (u.x < s.p_coat) {  // the coat's visible normals, in its own frame
        u.x = u.x / s.p_coat;
        vec3 v_c = vec3(dot(s.v, s.t_c), dot(s.v, s.b_c), s.NoV_c);
        vec3 l_c = reflect(-s.v, tangent_to_world(sample_ggx_vndf(u, v_c, s.a_c), s.n_c));
#if GBUFFER_HAS_TRANSMISSION
        if (!(dot(s.n_c, l_c) > 0.0)) return vec3(0.0);  // outside its lobe's hemisphere
#endif
        return l_c;
    }
    u.x = (u.x - s.p_coat) / (1.0 - s.p_coat);
#endif
#if GBUFFER_HAS_SHEEN
    if (u.x < s.p_sheen) {  // the sheen: uniform over the hemisphere
        u.x = u.x / s.p_sheen;
        return tangent_to_world(sample_uniform_hemisphere(u), s.n);
    }
    u.x = (u.x - s.p_sheen) / (1.0 - s.p_sheen);
#endif
    if (u.x < s.p_spec) {
        u.x = u.x / s.p_spec;
        vec3 v_t = vec3(dot(s.v, s.t), dot(s.v, s.b), s.NoV);
#if GBUFFER_HAS_ANISOTROPY
        vec3 h_t = surface_anisotropic(s) ? sample_ggx_vndf_anisotropic(u, v_t, s.alphas.x,
                                                                        s.alphas.y)
                                          : sample_ggx_vndf(u, v_t, s.a);
        vec3 h = s.t * h_t.x + s.b * h_t.y + s.n * h_t.z;
#else
        vec3 h = tangent_to_world(sample_ggx_vndf(u, v_t, s.a), s.n);
#endif
#if GBUFFER_HAS_TRANSMISSION
        vec3 l_s = reflect(-s.v, h);
        return dot(s.n, l_s) > 0.0 ? l_s : vec3(0.0);  // outside its lobe's hemisphere
#else
        return reflect(-s.v, h);
#endif
    }
    u.x = (u.x - s.p_spec) / (1.0 - s.p_spec);
#if GBUFFER_HAS_TRANSMISSION
    if (u.x < s.p_trans) {  // the BTDF: a visible normal, then mirrored or refracted below
        u.x = u.x / s.p_trans;
#if GBUFFER_HAS_DISPERSION
        float eta = s.eta;
        if (surface_disperses(s)) {  // a colour channel by s.channel_w, from the rest of u.x
            vec2 c = draw_channel(s.channel_w, u.x);
            u.x = c.y;
            eta = c.x < 0.5 ? s.etas.r : (c.x < 1.5 ? s.etas.g : s.etas.b);
        }
#define ETA_T eta  // the drawn channel's eta
#else
#define ETA_T s.eta
#endif
        vec3 v_t = vec3(dot(s.v, s.t), dot(s.v, s.b), s.NoV);
        vec3 h = tangent_to_world(sample_ggx_vndf(u, v_t, s.a), s.n);
        vec3 l_t = s.eta > 0.0 ? refract(-s.v, h, 1.0 / ETA_T)  // 0 on total internal reflection
                               : mirror_through(s.n, reflect(-s.v, h));
        return -dot(s.n, l_t) > 0.0 ? l_t : vec3(0.0);
    }
    u.x = (u.x - s.p_trans) / (1.0 - s.p_trans);
#endif
    return tangent_to_world(sample_cosine_hemisphere(u), s.n);
}

// The surface of normal n seen from v with the G-buffer's material (f0, f90: its Fresnel terms,
// lib/brdf.glsl surface_f0_f90), every field set (its diffuse not yet occluded); dfg: the DFG
// LUT's value at (n.v, r), for the caller's analytic terms.
Surface surface_init(vec3 n, vec3 v, vec3 albedo, float roughness, float metallic, vec3 f0,
                     float f90, vec2 coat, vec3 n_coat, vec4 sheen, out vec2 dfg) {
    Surface s;
    s.v = v;
    s.n = n;
    s.t = tangent_to_world(vec3(1.0, 0.0, 0.0), s.n);
    s.b = tangent_to_world(vec3(0.0, 1.0, 0.0), s.n);
    s.NoV = saturate(dot(s.n, s.v));
    float r = clamp_perceptual_roughness(roughness);
    s.a = r * r;
    s.f0 = f0;
    s.f90 = f90;
    dfg = ibl_dfg(u_env_dfg, s.NoV, r);
    s.spec_scale = MULTISCATTER != 0 ? ibl_energy_compensation(dfg, s.f0) : vec3(1.0);
    // the energy-conserving split of ggx_split_sum: diffuse keeps 1 - E_spec(n.v), a per-pixel
    // constant, so the integrand is the same BRDF the split-sum model approximates
    vec3 e_spec = ibl_specular_dfg(dfg, s.f0, s.f90) * s.spec_scale;
    s.diffuse = diffuse_color(albedo, metallic) * max(1.0 - e_spec, 0.0);
    // lobe choice from the unoccluded albedos: occlusion then scales values, not sample paths
    s.p_spec = specular_lobe_probability(s.diffuse, s.f0, s.f90, s.NoV);
#if GBUFFER_HAS_ANISOTROPY
    s.alphas = vec2(s.a);  // isotropic until surface_set_anisotropy
#endif
#if GBUFFER_HAS_IRIDESCENCE
    s.film = vec3(0.0);  // none until surface_set_iridescence
    s.film_outside = 1.0;
#endif
#if GBUFFER_HAS_SHEEN
    // the sheen (colour sheen.rgb, roughness sheen.a): drawn by its albedo max3(C) E(n.v)
    // against the base's, both kept reachable when both carry energy
    s.sheen = sheen.rgb;
    s.r_sheen = sheen.a;
    float c_max = max(max(sheen.r, sheen.g), sheen.b);
    s.e_sheen = c_max > 0.0 ? sheen_albedo(s.NoV, sheen.a) : 0.0;
    float e_sh = c_max * s.e_sheen;
    float e_under = (1.0 - e_sh) * dot(s.diffuse + f_schlick(s.f0, s.f90, s.NoV),
                                       vec3(0.2126, 0.7152, 0.0722));
    s.p_sheen = e_sh + e_under > 0.0 ? e_sh / (e_sh + e_under) : 0.0;
    if (e_sh > 0.0 && e_under > 0.0) s.p_sheen = clamp(s.p_sheen, 0.05, 0.95);
#endif
#if GBUFFER_HAS_CLEARCOAT
    // the coat (factor coat.x, perceptual roughness coat.y, normal n_coat): drawn by its albedo
    // w dfg_c.y against the base's (luminance), both kept reachable when both carry energy
    s.n_c = n_coat;
    s.t_c = tangent_to_world(vec3(1.0, 0.0, 0.0), n_coat);
    s.b_c = tangent_to_world(vec3(0.0, 1.0, 0.0), n_coat);
    s.NoV_c = saturate(dot(n_coat, v));
    float r_c = clamp_perceptual_roughness(coat.y);
    s.a_c = r_c * r_c;
    s.w_c = clearcoat_weight(coat.x, s.NoV_c);
    float e_coat = s.w_c * ibl_dfg(u_env_dfg, s.NoV_c, r_c).y;
    float e_base = (1.0 - s.w_c) * dot(s.diffuse + f_schlick(s.f0, s.f90, s.NoV),
                                       vec3(0.2126, 0.7152, 0.0722));
    s.p_coat = e_coat + e_base > 0.0 ? e_coat / (e_coat + e_base) : 0.0;
    if (e_coat > 0.0 && e_base > 0.0) s.p_coat = clamp(s.p_coat, 0.05, 0.95);
#endif
    return s;
}
