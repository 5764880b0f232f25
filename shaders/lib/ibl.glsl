// ibl.glsl - image-based lighting lookups used by the shading passes (split-sum, Karis 2013).
// Textures are built by viewer/ibl.py: the prefiltered chain is an equirect float texture whose
// mip level k holds radiance prefiltered with GGX at perceptual roughness k / (levels - 1)
// (GL_REPEAT in u, CLAMP_TO_EDGE in v, LINEAR_MIPMAP_LINEAR); the DFG LUT is RG float with
// x = n.v and y = perceptual roughness at texel centres (CLAMP_TO_EDGE, LINEAR).
// No uniforms, no main.
#include "lib/common.glsl"
#include "lib/equirect.glsl"

// The prefiltered level holding perceptual roughness r: level k was filtered at r_k =
// (k / (levels - 1))^2 (viewer/ibl.py: prefilter_roughness), so lod = sqrt(r) (levels - 1). The
// square spends the levels where the lobe changes fastest: with a linear map a near-mirror
// (r = 0.045, the shading clamp) read 22.5% of the r = 0.2 level (measured: the roughness clamp
// cost 23 dB PSNR against an exact mirror; see README "Stability at the extremes").
float prefilter_lod(float perceptual_roughness, float levels) {
    return sqrt(saturate(perceptual_roughness)) * max(levels - 1.0, 0.0);
}

// Karis 2013, "Real Shading in Unreal Engine 4", split-sum first term: prefiltered radiance along
// the (already environment-rotated) reflection direction r_ws, at prefilter_lod(r).
vec3 ibl_specular_radiance(sampler2D prefiltered, vec3 r_ws, float perceptual_roughness,
                           float levels) {
    return textureLod(prefiltered, equirect_uv(r_ws), prefilter_lod(perceptual_roughness, levels)).rgb;
}

// Karis 2013, split-sum second term: the DFG LUT at (n.v, perceptual roughness).
vec2 ibl_dfg(sampler2D dfg, float NoV, float perceptual_roughness) {
    // the LUT's texel centres sit on the end points (passes/ibl_dfg.comp): map [0, 1] onto them
    vec2 n = vec2(textureSize(dfg, 0));
    vec2 uv = (vec2(saturate(NoV), saturate(perceptual_roughness)) * (n - 1.0) + 0.5) / n;
    return textureLod(dfg, uv, 0.0).rg;
}

// Filament "Physically Based Rendering in Filament" sec. 5.3.4.3 (eq. 69): specular reflectance
// f0 * (dfg.y - dfg.x) + f90 * dfg.x, with dfg.x = integral of Fc * Vis and dfg.y = integral of
// Vis. With f90 = 1 this is mix(dfg.x, dfg.y, f0); f90 < 1 (f90_from_f0) lets f0 = 0 mean "no
// specular lobe" even at grazing angles.
vec3 ibl_specular_dfg(vec2 dfg, vec3 f0, float f90) {
    return f0 * (dfg.y - dfg.x) + f90 * dfg.x;
}

// Filament sec. 4.7.2 (multiple-scattering energy compensation, Fdez-Aguera 2019 / Kulla-Conty
// 2017): specular is multiplied by 1 + f0 (1 / dfg.y - 1) >= 1. dfg.y is floored at 1e-4.
vec3 ibl_energy_compensation(vec2 dfg, vec3 f0) {
    return 1.0 + f0 * (1.0 / max(dfg.y, 1e-4) - 1.0);
}
