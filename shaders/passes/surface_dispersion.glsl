// surface_dispersion.glsl (pass chunk) - KHR_materials_dispersion on passes/surface_mc.glsl's
// Surface: a dispersive volume's BTDF refracts each colour channel by its own eta, evaluated per
// channel and drawn by one channel at a time. Included by surface_mc.glsl (GBUFFER_HAS_DISPERSION
// with GBUFFER_HAS_TRANSMISSION), after the Surface struct and surface_set_transmission; the pure
// maths is lib/transmission.glsl's (dispersion_iors, dispersive_refraction_cos / _pdf,
// draw_channel). The reference does the same with the channels drawn uniformly
// (relight/reference/transmission.py btdf_sample_rgb): both are unbiased, this one less noisy.

// KHR_materials_dispersion (20 / V_d) of a volume of `ior` on a surface_set_transmission
// surface: each colour channel's eta from lib/transmission.glsl dispersion_iors, inverted
// inside as s.eta is (a thin wall, ior 0, keeps none).
void surface_set_dispersion(inout Surface s, float ior, float dispersion, bool inside) {
    vec3 iors = dispersion_iors(ior, dispersion);
    if (ior > 0.0) s.etas = inside ? 1.0 / iors : iors;
}

// Draw the channels in proportion to the path's throughput beta so far (uniformly before):
// a path that entered glass in one channel carries (almost) only that one, so it leaves in it.
void surface_weight_channels(inout Surface s, vec3 beta) {
    float sum = beta.r + beta.g + beta.b;
    if (sum > 0.0) s.channel_w = beta / sum;
}

// Whether the surface's BTDF disperses (its channels refract by different etas).
bool surface_disperses(Surface s) {
    return s.eta > 0.0 && s.etas.r != s.etas.b;
}

// The BTDF times |n.l| per colour channel, and the density of sample_surface_brdf's draw: a
// channel c drawn with probability w_c, then refracted by its eta, so the density is sum_c w_c
// pdf_c and f_k / pdf the balance heuristic's one-sample MIS over the three draws: unbiased for
// every channel k of throughput > 0 (whose w_k > 0), whatever w the path's past chose.
vec3 surface_btdf_cos_rgb(Surface s, vec3 l) {
    return surface_disperses(s) ? dispersive_refraction_cos(s.a, s.etas, s.n, s.v, l)
                                : vec3(surface_btdf_cos(s, l));
}

float surface_btdf_pdf_rgb(Surface s, vec3 l) {
    return surface_disperses(s) ? dispersive_refraction_pdf(s.a, s.etas, s.channel_w, s.n, s.v, l)
                                : surface_btdf_pdf(s, l);
}
