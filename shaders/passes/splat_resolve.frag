// splat_resolve.frag - normalise the splat accumulation by coverage and composite it over what the
// G-buffer held before (meshes, image stacks: bound as u_gbuffer<i>, a copy), premultiplied:
//   w_under = (1 - A) alpha_under,  alpha = A + w_under,
//   x = (sum_i T_i alpha_i x_i + w_under x_under) / alpha    (albedo, roughness, metallic, depth =
//       thesis eq. 6.10, specular and ao with the splats' 0.5 and 1), normal normalised (the
//       blended sum of unit normals, renormalised: a weighted mean direction),
//   depth with SPLAT_DEPTH_MEDIAN: the median depth instead (lib/splat.glsl, splat_median.frag),
//   color = sum_i T_i alpha_i c_i + w_under albedo_under     (premultiplied, no background),
//   emission = w_under emission_under / alpha                 (splats emit nothing),
//   dielectric (the glTF lobe, a >= 0, of a mesh underneath) = (A (0.04, 0.04, 0.04, 1) +
//       w_under dielectric_under) / alpha: the splats' own lobe is Filament's specular 0.5;
//       where none lies underneath (a < 0) it stays the background (the blended specular rules),
//   clearcoat factor = w_under clearcoat_under / alpha (splats have no coat; its roughness and
//       normal stay the surface's underneath), transmission factor likewise (splats are opaque;
//       the volume's IOR stays the surface's underneath), sheen colour = w_under sheen_under /
//       alpha (nor a sheen; its roughness stays the surface's underneath), anisotropy =
//       w_under anisotropy_under / alpha (nor an anisotropic lobe; its angle is read in the
//       frame of the blended normal).
// Pixels that nothing covers are discarded (they keep the background).
#define GBUFFER_WRITE
#define GBUFFER_READ
#include "generated/gbuffer.glsl"
#include "lib/splat.glsl"

uniform sampler2D u_accum0;  // (sum T a c, A)
uniform sampler2D u_accum1;  // (sum T a albedo, A)
uniform sampler2D u_accum2;  // (sum T a normal, A)
uniform sampler2D u_accum3;  // (sum T a roughness, sum T a metallic, sum T a depth, A)
#if SPLAT_DEPTH_MEDIAN
uniform sampler2D u_median;  // r: the median splat depth (splat_median.frag pass 2), else 3e38
#endif

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 a0 = texelFetch(u_accum0, px, 0);
    vec4 a1 = texelFetch(u_accum1, px, 0);
    vec4 a2 = texelFetch(u_accum2, px, 0);
    vec4 a3 = texelFetch(u_accum3, px, 0);
    GBuffer under = gbuffer_load(px);
    float coverage = a0.a;
    float w_under = (1.0 - coverage) * under.alpha;
    float total = coverage + w_under;
    if (total <= 0.0) {
        discard;
    }
    GBuffer g = under;
    g.alpha = total;
    g.albedo = (a1.rgb + w_under * under.albedo) / total;
    vec3 n = a2.xyz + w_under * under.normal;
    g.normal = dot(n, n) > 0.0 ? normalize(n) : vec3(0.0);
    g.roughness = (a3.r + w_under * under.roughness) / total;
    g.metallic = (a3.g + w_under * under.metallic) / total;
#if SPLAT_DEPTH_MEDIAN
    // the median of the splats and what lies under them: a splat's depth where the splats'
    // coverage reaches half the total, else the depth underneath
    float median = texelFetch(u_median, px, 0).r;
    bool on_splat = coverage >= splat_median_target(coverage, under.alpha) && median < 1e30;
    g.depth = on_splat ? median : under.depth;
#else
    g.depth = (a3.b + w_under * under.depth) / total;
#endif
    g.specular = (coverage * 0.5 + w_under * under.specular) / total;
    g.ao = (coverage + w_under * under.ao) / total;
    g.color = a0.rgb + w_under * under.albedo;
    g.emission = w_under * under.emission / total;  // splats emit nothing and hide what does
    g.clearcoat.x = w_under * under.clearcoat.x / total;
    g.transmission = w_under * under.transmission / total;
#if GBUFFER_HAS_SHEEN
    g.sheen.rgb = w_under * under.sheen.rgb / total;  // splats have no sheen either
#endif
#if GBUFFER_HAS_ANISOTROPY
    g.anisotropy = w_under * under.anisotropy / total;  // nor an anisotropic lobe
#endif
#if GBUFFER_HAS_IRIDESCENCE
    g.iridescence.x = w_under * under.iridescence.x / total;  // nor a film (its thickness, IOR:
#endif                                                        // the surface's underneath)
    if (under.dielectric.a >= 0.0) {
        g.dielectric = (coverage * vec4(0.04, 0.04, 0.04, 1.0) + w_under * under.dielectric)
                       / total;
    }
    gbuffer_store(g);
}
