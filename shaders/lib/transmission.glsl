// transmission.glsl - KHR_materials_transmission's specular BTDF and KHR_materials_volume's
// attenuation. Pure functions: no uniforms, no main. Twins: learned/twins/transmission.py.
//
// The glTF mix under the dielectric Fresnel layer, with this project's energy split (the base
// keeps 1 - E_spec(n.v) of itself, lib/shading.glsl): f = f_spec + (1 - E_spec) (1 - metallic)
// base_colour [(1 - T) / pi + T f_t], T the transmission factor and f_t one of two BTDFs of
// the base's GGX roughness a, both without a Fresnel factor of their own (the layer's split is
// it) and of directional albedo <= 1 from either side, so energy is never created:
// - thin-walled (no volume): the spec's BTDF, the GGX reflection lobe mirrored through the
//   surface plane (thin_transmission_cos): light leaves on the other side undeflected;
// - volume (thickness > 0): Walter et al. 2007's rough dielectric BTDF (rough_refraction_cos),
//   eta = eta_l / eta_v the ratio of the IORs on the light's and the viewer's sides. The
//   radiance scale (eta_v / eta_l)^2 of a crossing is left out: it cancels on every path that
//   enters and leaves a closed volume, which is what the path tracer and the reference trace.
#include "lib/common.glsl"
#include "lib/brdf.glsl"

// l mirrored through the plane of normal n: the thin wall's transmitted direction is the
// reflection lobe's, on the other side.
vec3 mirror_through(vec3 n, vec3 l) {
    return l - 2.0 * dot(n, l) * n;
}

// The thin-walled BTDF times |n.l| for l below the surface (0 above): D(n.h') V(n.v, |n.l|) |n.l|
// with h' the half vector of v and l mirrored above (KHR_materials_transmission, thin-walled).
float thin_transmission_cos(float a, vec3 n, vec3 v, vec3 l) {
    float NoL = -dot(n, l);
    if (!(NoL > 0.0)) return 0.0;
    vec3 h = half_vector(v, mirror_through(n, l));
    float NoV = saturate(dot(n, v));
    return d_ggx(saturate(dot(n, h)), a) * v_smith_ggx_correlated(NoV, NoL, a) * NoL;
}

// Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", eq. 16: the
// half vector of a refraction from v (the viewer's side, above n) to l (below) with
// eta = eta_l / eta_v, normalize(-(v + eta l)) turned to n's side; 0 where v + eta l vanishes.
vec3 refraction_half_vector(vec3 n, vec3 v, vec3 l, float eta) {
    vec3 h = v + eta * l;
    float len2 = dot(h, h);
    if (!(len2 > 1e-12)) return vec3(0.0);
    h *= inversesqrt(len2);
    return dot(n, h) < 0.0 ? -h : h;
}

// Walter et al. 2007, eq. 21 without its Fresnel factor and radiance scale, times |n.l|:
// |v.h| |l.h| eta^2 D(h) G2(v, l) / (|n.v| (v.h + eta l.h)^2), G2 = 4 V n.v |n.l| (the
// height-correlated Smith visibility V of lib/brdf.glsl); 0 unless v is above, l below and
// both on their own sides of the microfacet (v.h > 0 > l.h). Its integral over l is
// int D G2 (v.h) / (n.v) dh <= 1 (the visible normals' normalisation).
float rough_refraction_cos(float a, float eta, vec3 n, vec3 v, vec3 l) {
    float NoV = dot(n, v);
    float NoL = -dot(n, l);
    if (!(NoV > 0.0) || !(NoL > 0.0)) return 0.0;
    vec3 h = refraction_half_vector(n, v, l, eta);
    float VoH = dot(v, h);
    float LoH = dot(l, h);
    if (!(VoH > 0.0) || !(LoH < 0.0)) return 0.0;
    float denom = VoH + eta * LoH;
    float jacobian = eta * eta * (-LoH) / max(denom * denom, 1e-20);  // d(omega_h) / d(omega_l)
    return 4.0 * v_smith_ggx_correlated(NoV, NoL, a) * NoL * d_ggx(dot(n, h), a) * VoH
           * jacobian;
}

// The density (solid angle) of l drawn by refracting v through a visible normal (Heitz 2018's
// sample_ggx_vndf, then refract with eta): D_v(h) |d(omega_h) / d(omega_l)|, D_v(h) =
// G1(v) D(h) (v.h) / (n.v) written as 2 D(h) (v.h) / (n.v + sqrt(a^2 + (1 - a^2) n.v^2)).
float rough_refraction_pdf(float a, float eta, vec3 n, vec3 v, vec3 l) {
    float NoV = dot(n, v);
    if (!(NoV > 0.0) || !(-dot(n, l) > 0.0)) return 0.0;
    vec3 h = refraction_half_vector(n, v, l, eta);
    float VoH = dot(v, h);
    float LoH = dot(l, h);
    if (!(VoH > 0.0) || !(LoH < 0.0)) return 0.0;
    float a2 = sq(saturate(a));
    float denom = VoH + eta * LoH;
    float jacobian = eta * eta * (-LoH) / max(denom * denom, 1e-20);
    return 2.0 * d_ggx(dot(n, h), a) * VoH / (NoV + sqrt(a2 + (1.0 - a2) * NoV * NoV))
           * jacobian;
}

// KHR_materials_dispersion: the IORs the red, green and blue channels refract by, from the
// volume's `ior` and dispersion = 20 / V_d (V_d the Abbe number; 0: none) as three.js and the
// Khronos sample viewer spread them: half spread (ior - 1) 0.025 dispersion about ior (red
// least, blue most). A thin wall's ior 0 stays 0 in every channel.
vec3 dispersion_iors(float ior, float dispersion) {
    if (!(ior > 0.0)) return vec3(0.0);
    float half_spread = (ior - 1.0) * 0.025 * dispersion;
    return vec3(ior - half_spread, ior, ior + half_spread);
}

// rough_refraction_cos per colour channel, each refracting by its own eta (etas: eta_l / eta_v
// of red, green, blue; KHR_materials_dispersion).
vec3 dispersive_refraction_cos(float a, vec3 etas, vec3 n, vec3 v, vec3 l) {
    return vec3(rough_refraction_cos(a, etas.r, n, v, l), rough_refraction_cos(a, etas.g, n, v, l),
                rough_refraction_cos(a, etas.b, n, v, l));
}

// The density of l drawn by a colour channel chosen with probabilities w (summing to 1), then
// refracted by its eta through a visible normal: the channels' rough_refraction_pdf weighted by w.
float dispersive_refraction_pdf(float a, vec3 etas, vec3 w, vec3 n, vec3 v, vec3 l) {
    return dot(w, vec3(rough_refraction_pdf(a, etas.r, n, v, l),
                       rough_refraction_pdf(a, etas.g, n, v, l),
                       rough_refraction_pdf(a, etas.b, n, v, l)));
}

// A colour channel drawn with probabilities w (summing to 1) by u in [0, 1): (its index 0, 1 or
// 2; u rescaled to [0, 1] within its share, for the draw that follows). A channel of
// probability 0 is never returned (where rounding leaves u past w.r + w.g, green stands in
// for a blue of 0).
vec2 draw_channel(vec3 w, float u) {
    if (u < w.r) return vec2(0.0, u / w.r);
    u -= w.r;
    if (u < w.g || !(w.b > 0.0)) return vec2(1.0, saturate(u / max(w.g, 1e-30)));
    return vec2(2.0, saturate((u - w.g) / w.b));
}

// Beer-Lambert: the share of light left after `distance` through a medium of attenuation
// coefficient sigma = -ln(attenuationColor) / attenuationDistance (KHR_materials_volume).
vec3 volume_attenuation(vec3 sigma, float distance) {
    return exp(-sigma * max(distance, 0.0));
}

// ---- the rasterised approximation (the forward pass: viewer/passes/forward.py) -----------------
// As three.js renders KHR_materials_transmission (transmission_pars_fragment): what is behind a
// transmissive surface is read from a mip-mapped copy of the opaque frame, where the view ray
// leaves the surface, at a level its roughness chooses. One refraction, no inner reflections:
// an approximation of the BTDFs above, which the path tracer follows exactly.

// three.js's getVolumeTransmissionRay: from the entry point to where the view ray leaves a volume
// of `thickness` (KHR_materials_volume thicknessFactor): -v refracted into a medium of `ior`
// (n faces v) times thickness; 0 for a thin wall (ior 0 or thickness 0) and under total internal
// reflection (refract's 0: only an ior < 1 admits it), so light then goes straight through.
vec3 volume_exit_offset(vec3 n, vec3 v, float thickness, float ior) {
    if (!(ior > 0.0) || !(thickness > 0.0)) return vec3(0.0);
    vec3 t = refract(-v, n, 1.0 / ior);
    float len2 = dot(t, t);
    if (!(len2 > 1e-12)) return vec3(0.0);
    return t * (inversesqrt(len2) * thickness);
}

// three.js's applyIorToRoughness and level choice: the mip level of the opaque frame's copy read
// through a surface of perceptual roughness r, for a copy log2_width levels above 1 texel wide:
// log2_width r, with a volume's r scaled by clamp(2 ior - 2, 0, 1) (an IOR of 1 bends nothing,
// so nothing blurs; 1.5 and above: r itself); a thin wall (ior 0) blurs by r, its BTDF being the
// reflection lobe mirrored.
float transmission_lod(float r, float ior, float log2_width) {
    float rough = ior > 0.0 ? r * saturate(2.0 * ior - 2.0) : r;
    return log2_width * saturate(rough);
}

// KHR_materials_transmission in a diffuse term weighted by irradiance (split-sum, Blinn-Phong):
// the base's share T receives pi times the radiance refracted through the surface in place of its
// irradiance E, so the lobe's own weight (1 - E_spec(n.v) split-sum, 1 - f0 Blinn-Phong) applies
// to the transmitted light as it does to the diffuse: three.js's mix(totalDiffuse, transmitted,
// T), whose transmitted light carries (1 - F) too. A Lambertian base of albedo c returns
// c E / pi, so the T share returns c L_refracted: the base colour tints what passes through.
vec3 transmission_irradiance(vec3 irradiance, float transmission, vec3 refracted) {
    return mix(irradiance, PI * refracted, saturate(transmission));
}
