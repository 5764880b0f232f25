// ibl_dfg.comp - the split-sum DFG LUT (Karis 2013; Filament's multiscatter form, sec. 5.3.4.3):
// texel (i, j) holds, at n.v = i/(N - 1) (at least 1e-4) and perceptual roughness r = j/(N - 1)
// (alpha = r^2) — texel centres on both end points, so lookups at n.v = 1 or r = 1 are exact
// rather than clamped half a texel inside (which cost 3% at r = 1; see ibl_dfg) —
//   x = (1/S) sum Fc * G,  y = (1/S) sum G,  G = V(n.v, n.l, a) 4 (v.h)(n.l) / (n.h),  Fc = (1 - v.h)^5
// over S GGX-importance-sampled half vectors (Hammersley). y is the single-scatter directional
// albedo for f0 = 1 (-> 1 for smooth surfaces), clamped to <= 1. Twin: learned.twins.ibl.dfg_lut.
// The same samples also give u_dominant: the specular dominant direction's lerp factor t of
// specular_dominant_direction (lib/ibl.glsl): the mean direction m = sum G l of the f (n.l) lobe
// (l in the plane of n and v; F = 1) written as normalize(mix(n, r, t)), r = reflect(-v, n):
//   t = m.x / (m.x (1 - n.v) - sin(theta_v) m.z), clamped to [0, 1]
// (a 0/0 limit at n.v = 1, where r = n and t does not matter: there it is taken at n.v = 0.999).
// Twin: learned.twins.ibl.dominant_lut.
#include "lib/common.glsl"
#include "lib/brdf.glsl"
#include "lib/sampling.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rg32f, binding = 0) writeonly uniform image2D u_dst;
layout(r32f, binding = 1) writeonly uniform image2D u_dominant;
uniform uint u_samples;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_dst);
    if (any(greaterThanEqual(p, size))) return;
    float NoV = max(float(p.x) / float(size.x - 1), 1e-4);
    float r = float(p.y) / float(size.y - 1);
    float a = r * r;
    vec3 v = vec3(sqrt(max(1.0 - NoV * NoV, 0.0)), 0.0, NoV);
    vec2 acc = vec2(0.0);
    // the dominant direction's moments at n.v <= 0.999 (see the header)
    float NoV_t = min(NoV, 0.999);
    float sin_t = sqrt(1.0 - NoV_t * NoV_t);
    vec3 v_t = vec3(sin_t, 0.0, NoV_t);
    vec2 m = vec2(0.0);
    for (uint i = 0u; i < u_samples; ++i) {
        vec3 h = importance_sample_ggx(hammersley(i, u_samples), a);
        float VoH = dot(v, h);
        vec3 l = 2.0 * VoH * h - v;
        float NoL = l.z;
        if (NoL > 0.0) {
            float g = v_smith_ggx_correlated(NoV, NoL, a) * 4.0 * max(VoH, 0.0) * NoL
                      / max(h.z, 1e-30);
            float fc = f_schlick(vec3(0.0), 1.0, VoH).x;
            acc += vec2(g * fc, g);
        }
        float VoH_t = dot(v_t, h);
        vec3 l_t = 2.0 * VoH_t * h - v_t;
        if (l_t.z > 0.0) {
            m += v_smith_ggx_correlated(NoV_t, l_t.z, a) * 4.0 * max(VoH_t, 0.0) * l_t.z
                 / max(h.z, 1e-30) * l_t.xz;
        }
    }
    // The estimate of y overshoots 1 by up to ~2e-4 at grazing n.v on smooth surfaces (the exact
    // albedo is <= 1): clamp, keeping x <= y.
    vec2 dfg = acc / float(max(u_samples, 1u));
    dfg.y = min(dfg.y, 1.0);
    dfg.x = min(dfg.x, dfg.y);
    imageStore(u_dst, p, vec4(dfg, 0.0, 0.0));
    float t = m.x / min(m.x * (1.0 - NoV_t) - sin_t * m.y, -1e-30);
    imageStore(u_dominant, p, vec4(clamp(t, 0.0, 1.0), 0.0, 0.0, 0.0));
}
