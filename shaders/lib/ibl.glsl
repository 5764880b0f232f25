// ibl.glsl - image-based lighting lookups used by the shading passes (split-sum, Karis 2013).
// Textures are built by viewer/environment/ibl.py: the prefiltered chain is an equirect float texture whose
// mip level k holds radiance prefiltered with GGX at perceptual roughness k / (levels - 1)
// (GL_REPEAT in u, CLAMP_TO_EDGE in v, LINEAR_MIPMAP_LINEAR); the DFG LUT is RG float with
// x = n.v and y = perceptual roughness at texel centres (CLAMP_TO_EDGE, LINEAR).
// No uniforms, no main.
#include "lib/common.glsl"
#include "lib/equirect.glsl"

// The prefiltered level holding perceptual roughness r. Level k >= 1 was filtered at alpha_k =
// 2^(k - (levels - 1)) (viewer/environment/ibl.py: prefilter_roughness): alpha doubles per level as the texel
// size does, so every level's lobe spans the same number of its texels (Krivanek & Colbert 2008's
// rule, texel solid angle ~ lobe solid angle, applied to the chain itself: UE4's log2 roughness
// <-> mip map is the same idea). The last level is alpha = 1; below level 1 (alpha < alpha_1) the
// lookup blends the unfiltered level 0 towards level 1 linearly in alpha. The previous map,
// r_k = (k / (levels - 1))^2, kept r = 0.04 at level 1 (256 texels around for a 512-wide
// environment), a lobe 8x narrower than a texel: r = 0.05 read a half-resolution copy of the sun
// (README "Split-sum accuracy").
float prefilter_lod(float perceptual_roughness, float levels) {
    float last = max(levels - 1.0, 0.0);
    float r = saturate(perceptual_roughness);
    float a = r * r;
    float a1 = exp2(1.0 - last);  // alpha of level 1
    return a < a1 ? a / a1 * min(last, 1.0) : last + log2(a);
}

// Karis 2013, "Real Shading in Unreal Engine 4", split-sum first term: prefiltered radiance along
// the (already environment-rotated) reflection direction r_ws, at prefilter_lod(r).
vec3 ibl_specular_radiance(sampler2D prefiltered, vec3 r_ws, float perceptual_roughness,
                           float levels) {
    return textureLod(prefiltered, equirect_uv(r_ws), prefilter_lod(perceptual_roughness, levels)).rgb;
}

// The split-sum lookup of a pass that shades the environment's sun as a light (SUN_LIGHT,
// viewer/environment/sun.py): `sunless`, the chain without the sun, and where the light shades only the share
// w < 1 of the sun's specular light (lib/shading.glsl sun_specular_weight) the whole environment's
// chain `full` mixed back in for the rest, mix(full, sunless, w); one lookup where w = 1.
vec3 ibl_specular_radiance_sun(sampler2D sunless, sampler2D full, vec3 r_ws,
                               float perceptual_roughness, float levels, float w) {
    vec3 p = ibl_specular_radiance(sunless, r_ws, perceptual_roughness, levels);
    if (!(w < 1.0)) return p;
    return mix(ibl_specular_radiance(full, r_ws, perceptual_roughness, levels), p, w);
}

// The diffuse term's irradiance E(n) at the (already environment-rotated) unit normal n_ws: the
// exact cosine convolution of the environment (viewer/environment/irradiance.py), an equirect map whose rows
// run from pole to pole (row j at polar angle pi j / (h - 1): the poles are texels, so a floor's
// normal reads its own value, not a ring half a texel away), bilinear in between. E = pi for a
// unit constant environment; diffuse radiance is albedo / pi * E.
vec3 irradiance_lookup(sampler2D irradiance, vec3 n_ws) {
    vec2 uv = equirect_uv(n_ws);
    float h = float(textureSize(irradiance, 0).y);
    uv.y = (uv.y * (h - 1.0) + 0.5) / h;
    return textureLod(irradiance, uv, 0.0).rgb;
}

// Karis 2013, split-sum second term: the DFG LUT at (n.v, perceptual roughness).
vec2 ibl_dfg(sampler2D dfg, float NoV, float perceptual_roughness) {
    // the LUT's texel centres sit on the end points (passes/ibl_dfg.comp): map [0, 1] onto them
    vec2 n = vec2(textureSize(dfg, 0));
    vec2 uv = (vec2(saturate(NoV), saturate(perceptual_roughness)) * (n - 1.0) + 0.5) / n;
    return textureLod(dfg, uv, 0.0).rg;
}

// The specular dominant direction's lerp factor t at (n.v, perceptual roughness): a LUT laid out
// as the DFG LUT (passes/ibl_dfg.comp writes both from the same samples).
float ibl_dominant_factor(sampler2D dominant, float NoV, float perceptual_roughness) {
    vec2 n = vec2(textureSize(dominant, 0));
    vec2 uv = (vec2(saturate(NoV), saturate(perceptual_roughness)) * (n - 1.0) + 0.5) / n;
    return textureLod(dominant, uv, 0.0).r;
}

// Lagarde & de Rousiers 2014, "Moving Frostbite to PBR", sec. 4.9.3 (listing 22): the
// prefiltered lobe (filtered with n = v = r) is looked up along the BRDF lobe's dominant
// direction, between r = reflect(-v, n) and n: normalize(mix(n, r, t)). Frostbite fits t to
// roughness alone (t = s (sqrt(s) + alpha), s = 1 - alpha); ours is the lobe's measured mean
// direction at each (n.v, roughness), from the DFG LUT's samples (ibl_dominant_factor). On a
// sphere under a sunny sky at roughness 0.8, the split-sum with an exact prefilter is +74% bright
// along r, +12% along Frostbite's fit, +0.3% along the mean (README "Split-sum accuracy").
vec3 specular_dominant_direction(vec3 n, vec3 r, float t) {
    return normalize(mix(n, r, t));
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
