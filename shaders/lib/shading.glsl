// shading.glsl - material parameterisation and the per-pixel shading models, written against
// pre-looked-up lighting (irradiance, prefiltered radiance, DFG terms) so each is a pure function.
// Roughness clamping and f0 live in brdf.glsl (clamp_perceptual_roughness, compute_f0). The passes (shaders/passes/shade_*.frag) do the texture lookups.
#include "lib/common.glsl"
#include "lib/brdf.glsl"
#include "lib/ibl.glsl"

// Filament material model: metals have no diffuse lobe.
vec3 diffuse_color(vec3 albedo, float metallic) {
    return albedo * (1.0 - saturate(metallic));
}

// A unit normal and n.v that stays away from 0: back-facing or grazing normals are bent towards
// the viewer instead of producing negative n.v (which makes the DFG lookup and 1/n.v blow up).
vec3 shading_normal(vec3 n, vec3 v) {
    float len2 = dot(n, n);
    if (!(len2 > 1e-12)) {  // zero-length or NaN normal: face the viewer
        return v;
    }
    n *= inversesqrt(len2);
    float nv = dot(n, v);
    // remove the part of n that points away from v, keeping a minimum n.v of 1e-4
    return nv < 1e-4 ? normalize(n + (1e-4 - nv) * v) : n;
}

// Split-sum GGX image-based lighting (Karis 2013; Filament's IBL evaluation).
// irradiance: E(n) (= pi for a unit constant environment); prefiltered: radiance prefiltered with
// the GGX lobe along the reflected direction; dfg: the LUT terms at (n.v, r). The specular
// directional albedo e_spec (times the multiple-scattering compensation when on) is what the
// specular lobe reflects; the diffuse lobe gets the rest, (1 - e_spec), so a white surface never
// reflects more than it receives (Filament scales diffuse by 1 - E as well, but before the
// compensation, which lets a white dielectric exceed the furnace by up to ~1.5%).
vec3 ggx_split_sum(vec3 diffuse, vec3 f0, float f90, float ao, vec3 irradiance, vec3 prefiltered,
                   vec2 dfg, float multiscatter) {
    vec3 e_spec = ibl_specular_dfg(dfg, f0, f90);
    if (multiscatter > 0.5) {
        e_spec *= ibl_energy_compensation(dfg, f0);
    }
    vec3 fd = diffuse * irradiance * INV_PI * ao * max(1.0 - e_spec, 0.0);
    return fd + e_spec * prefiltered;
}

// Specular occlusion from ambient occlusion (Lagarde & de Rousiers 2014, "Moving Frostbite to
// PBR", sec. 4.10.2; Filament's computeSpecularAO, three.js's computeSpecularOcclusion): the
// share of the prefiltered environment light a lobe still sees where a share 1 - ao of the
// hemisphere is occluded. A narrow lobe seen head-on keeps more of it than ao (it looks out of
// the opening), a rough or grazing one about ao; exactly 1 where ao = 1, 0 where ao = 0.
// NoV: n.v in [0, 1]; a: alpha (clamped perceptual roughness squared), as Filament passes it.
float specular_occlusion(float NoV, float ao, float a) {
    return saturate(pow(NoV + ao, exp2(-16.0 * a - 1.0)) - 1.0 + ao);
}

// Blinn-Phong under environment light (the thesis baseline): Lambert diffuse plus a normalised,
// Fresnel-free Blinn-Phong lobe whose convolution with the environment is the prefiltered radiance
// at the matching roughness. The lobe integrates to 1, so the specular colour f0 scales it directly
// and the diffuse keeps the rest, (1 - f0).
vec3 blinn_phong(vec3 diffuse, vec3 f0, float ao, vec3 irradiance, vec3 prefiltered) {
    return diffuse * irradiance * INV_PI * ao * (1.0 - f0) + f0 * prefiltered;
}

// ---- one directional light ([light]) -----------------------------------------------------------
// A light at infinity of irradiance E (on a surface facing it) from the unit direction l adds
// L_o = f(v, l) E (n.l), 0 when the light is below the surface (n.l <= 0). Nothing shadows it, and
// ambient occlusion (the environment's visibility) does not apply to it. n, v, l: unit, world space;
// a = alpha (clamped perceptual roughness squared).

// half_vector(v, l) is in common.glsl (shared with the neural teacher's specular input).

// Cook-Torrance GGX + Lambert, the BRDF ggx_split_sum approximates and ggx_mc integrates:
//   f = diffuse (1 - E_spec) / pi + D_GGX(h) V_SmithGGXCorrelated(v, l) F_Schlick(v.h) c_ms
// (Walter et al. 2007, eq. 20 with Heitz 2014's V = G2 / (4 NoV NoL)), with the specular albedo
// E_spec = (f0 (dfg.y - dfg.x) + f90 dfg.x) c_ms and the multiple-scattering compensation
// c_ms = 1 + f0 (1/dfg.y - 1) (1 without multiscatter) from the DFG terms at (n.v, r): the energy
// split of ggx_split_sum and of shade_ggx_mc.frag's Surface, so light and environment see one BRDF.
//
// ggx_environment_sun: that BRDF under the environment's sun (viewer/environment/sun.py: a compact, very bright
// region taken out of the environment as a light at infinity, irradiance E from l), its specular
// term weighted by w = sun_specular_weight (the diffuse term is whole: the SH irradiance leaves the
// sun out). Shaded as a point, which is right for a lobe wider than the sun: at the grazing angles
// where the round prefiltered lookup cannot follow the stretched, horizon-clipped lobe, the point
// evaluates the true BRDF (README "Split-sum accuracy").
vec3 ggx_environment_sun(vec3 diffuse, vec3 f0, float f90, float a, vec2 dfg, float multiscatter,
                         vec3 n, vec3 v, vec3 l, vec3 irradiance, float specular_weight) {
    float NoL = dot(n, l);
    if (!(NoL > 0.0)) return vec3(0.0);
    vec3 h = half_vector(v, l);
    float NoV = saturate(dot(n, v));
    float NoH = saturate(dot(n, h));
    float VoH = saturate(dot(v, h));
    vec3 spec_scale = multiscatter > 0.5 ? ibl_energy_compensation(dfg, f0) : vec3(1.0);
    vec3 e_spec = ibl_specular_dfg(dfg, f0, f90) * spec_scale;
    vec3 fd = diffuse * INV_PI * max(1.0 - e_spec, 0.0);
    vec3 fs = d_ggx(NoH, a) * v_smith_ggx_correlated(NoV, NoL, a) * f_schlick(f0, f90, VoH)
              * spec_scale;
    return (fd + fs * specular_weight) * irradiance * NoL;
}

// The share w of the sun's specular light that ggx_environment_sun shades (shade_ggx_split_sum.frag
// looks the rest up in the prefiltered chain of the whole environment): 0 while the GGX lobe is
// narrower than the sun (alpha <= t/2, t the sun's angular radius; the prefiltered chain resolves
// the sun's texels there, as a pixel-centre path tracer sees them, and a point light would give a
// spike), 1 once it is as wide as the sun (alpha >= t), linear in alpha between.
float sun_specular_weight(float a, float sun_radius) {
    return saturate(2.0 * a / max(sun_radius, 1e-6) - 1.0);
}

// atan(z) - z without the cancellation of the difference at small z: its Taylor series below
// 0.35 (terms to z^17: 1e-7 relative), atan(z) - z above (every extracted light has z < 0.1).
float atan_minus_z(float z) {
    float z2 = z * z;
    if (z >= 0.35) return atan(z) - z;
    float p = -1.0 / 17.0;
    p = 1.0 / 15.0 + z2 * p;
    p = -1.0 / 13.0 + z2 * p;
    p = 1.0 / 11.0 + z2 * p;
    p = -1.0 / 9.0 + z2 * p;
    p = 1.0 / 7.0 + z2 * p;
    p = -1.0 / 5.0 + z2 * p;
    p = 1.0 / 3.0 + z2 * p;
    return -z * z2 * p;
}

// A disc light at infinity of angular radius t (an environment light, viewer/environment/sun.py) as a
// direction and a factor on its irradiance E: returns (l_b, s), shaded as a light from l_b of
// irradiance E s. Its irradiance on a surface of normal n is E max(n.l, 0) while the disc is
// wholly above the horizon (s = 1, l_b = l) and E c while the horizon cuts it, c the cut disc's
// cosine-weighted share (Lagarde & de Rousiers 2014, "Moving Frostbite to PBR", sec. 4.7.2,
// listing 7, illuminanceSphereOrDisk, divided by its unclipped pi sin^2 t; with x = cot t,
// z = x^-1 sin(theta) sqrt(1 - y^2), its -x z sin^2 t (..) + atan(z) is rewritten
// z sin^2 t + (atan(z) - z): no cancellation for small discs), there l_b is l lifted to
// n.l_b >= 1e-3 for the BRDF (a point light at l gives 0 half a disc below the horizon, where
// the floor of a sunset still sees half the sun).
vec4 disc_light(vec3 n, vec3 l, float radius) {
    float NoL = dot(n, l);
    float s2 = max(sq(sin(min(radius, 1.5))), 1e-12);
    float c = max(NoL, 0.0);  // wholly above (or below) the horizon
    if (NoL * NoL < s2) {
        float sin_t = sqrt(max(1.0 - NoL * NoL, 0.0));
        float x = sqrt(1.0 / s2 - 1.0);
        float y = clamp(-x * NoL / sin_t, -1.0, 1.0);
        float z = sin_t * sqrt(max(1.0 - y * y, 0.0)) / x;
        c = max((NoL * acos(y) + z + atan_minus_z(z) / s2) * INV_PI, 0.0);
    }
    vec3 lb = NoL >= 1e-3 ? l : normalize(l + (1e-3 - NoL) * n);
    return vec4(lb, c > 0.0 ? c / dot(n, lb) : 0.0);
}

// The scene's [light]: the whole BRDF (w = 1).
vec3 ggx_directional_light(vec3 diffuse, vec3 f0, float f90, float a, vec2 dfg, float multiscatter,
                           vec3 n, vec3 v, vec3 l, vec3 irradiance) {
    return ggx_environment_sun(diffuse, f0, f90, a, dfg, multiscatter, n, v, l, irradiance, 1.0);
}

// Blinn-Phong under the light, split like blinn_phong(): Lambert keeping (1 - f0) plus the
// normalised, Fresnel-free Blinn-Phong specular BRDF of Akenine-Moller, Haines & Hoffman,
// "Real-Time Rendering" 3rd ed. (2008), eq. 7.49: f_s = f0 (s + 8) / (8 pi) (n.h)^s, with the
// exponent s = blinn_phong_shininess(a) that matches the GGX alpha (Walter et al. 2007, sec. 5.2).
vec3 blinn_phong_directional_light(vec3 diffuse, vec3 f0, float a, vec3 n, vec3 v, vec3 l,
                                   vec3 irradiance) {
    float NoL = dot(n, l);
    if (!(NoL > 0.0)) return vec3(0.0);
    float NoH = saturate(dot(n, half_vector(v, l)));
    float s = blinn_phong_shininess(a);
    // pow(0, 0) is undefined in GLSL: the floor makes NoH^0 = 1 (as d_blinn_phong does)
    float lobe = (s + 8.0) * (0.125 * INV_PI) * pow(max(NoH, 1e-30), s);
    return (diffuse * INV_PI * (1.0 - f0) + f0 * lobe) * irradiance * NoL;
}
