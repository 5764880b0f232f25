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
vec3 ggx_split_sum(vec3 diffuse, vec3 f0, float ao, vec3 irradiance, vec3 prefiltered, vec2 dfg,
                   float multiscatter) {
    vec3 e_spec = ibl_specular_dfg(dfg, f0, f90_from_f0(f0));
    if (multiscatter > 0.5) {
        e_spec *= ibl_energy_compensation(dfg, f0);
    }
    vec3 fd = diffuse * irradiance * INV_PI * ao * max(1.0 - e_spec, 0.0);
    return fd + e_spec * prefiltered;
}

// Blinn-Phong under environment light (the thesis baseline): Lambert diffuse plus a normalised,
// Fresnel-free Blinn-Phong lobe whose convolution with the environment is the prefiltered radiance
// at the matching roughness. The lobe integrates to 1, so the specular colour f0 scales it directly
// and the diffuse keeps the rest, (1 - f0).
vec3 blinn_phong(vec3 diffuse, vec3 f0, float ao, vec3 irradiance, vec3 prefiltered) {
    return diffuse * irradiance * INV_PI * ao * (1.0 - f0) + f0 * prefiltered;
}
