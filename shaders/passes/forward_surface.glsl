// forward_surface.glsl - the forward pass's G-buffer access (glTF alphaMode BLEND). The forward
// pass compiles a model's own lighting pass (shade_<model>.frag) unchanged, with this in place of
// the generated gbuffer_load: instead of reading the opaque G-buffer at `pixel`, it returns the
// blended surface at this fragment (mesh_surface.glsl) with coverage = its glTF alpha, so the
// pass's write_radiance(c, background, alpha) with BACKGROUND_ENVIRONMENT 0 writes the
// premultiplied colour (c alpha, alpha) that the fixed-function blend (ONE, ONE_MINUS_SRC_ALPHA)
// puts "over" the shaded radiance. Same shading code as the deferred pass by construction.
// The fragment is discarded where the opaque G-buffer (meshes, image stacks, splats) is nearer:
// a depth test against its depth channel (gbuffer_load_opaque, the generated loader renamed by
// viewer/passes/forward.py), which the forward pass never writes.
// USE_TRANSMISSION (KHR_materials_transmission / _volume, drawn here under the rasterising models:
// viewer/passes/forward.py): FORWARD_TRANSMISSION is defined for the lighting pass, which lets the
// base's share T receive refracted_radiance in place of its irradiance (lib/transmission.glsl
// transmission_irradiance) and lights only the rest, 1 - T, of its diffuse with its lights; an
// OPAQUE (or MASK, cut at u_alpha_cutoff) transmissive surface covers its pixel (alpha 1): what is
// behind it comes through refracted_radiance, not through the blend.
// USE_THICKNESS_MAP (with USE_TRANSMISSION and a volume): KHR_materials_volume's thicknessTexture,
// its G times u_thickness, is the thickness refracted_radiance goes through at this fragment (read
// here: the G-buffer has no thickness channel, the traced volume being the mesh itself).
// USE_DISPERSION (with USE_TRANSMISSION, a dispersive volume): refracted_radiance per channel
// where the layout has the dispersion channel (render.specialize = false's all-features layout
// has none: the volume then refracts by its one IOR).
// Included by the virtual generated/gbuffer.glsl of viewer/passes/forward.py, after the layout's
// struct and loader.
#include "passes/mesh_surface.glsl"

#ifdef USE_TRANSMISSION
#define FORWARD_TRANSMISSION 1
#include "lib/transmission.glsl"

uniform sampler2D u_transmission_frame;  // the opaque frame's radiance, mip-mapped, trilinear
uniform float u_transmission_log2_width; // log2 of its width in texels
uniform float u_thickness;               // KHR_materials_volume thicknessFactor (world units)
uniform vec3 u_attenuation_sigma;        // -ln(attenuationColor) / attenuationDistance, 0: clear
uniform mat4 u_view;                     // world -> view (as the vertex stage's)
uniform mat4 u_projection;               // view -> clip
#ifdef ALPHA_MASK
uniform float u_alpha_cutoff;            // glTF alphaCutoff
#endif
#ifdef USE_THICKNESS_MAP
uniform sampler2D u_thickness_map;       // G = thickness (x u_thickness)
uniform int u_thickness_set;
uniform mat3 u_thickness_uv;
uniform vec2 u_thickness_mirror;
float forward_thickness = 0.0;           // u_thickness x the map's G here (gbuffer_load sets it)
#define TRANSMISSION_THICKNESS forward_thickness
#else
#define TRANSMISSION_THICKNESS u_thickness
#endif

// The opaque frame's radiance seen through this fragment (three.js's getIBLVolumeRefraction, our
// own): the view ray refracted by n (facing v) through a volume of u_thickness (times the thickness
// map's G with USE_THICKNESS_MAP; thin wall: straight on), the copy read where it leaves, projected
// to the screen, at the level the roughness chooses, attenuated along the way by Beer-Lambert. An
// exit point behind the camera is read at this fragment's own pixel; one off screen at the nearest
// edge. `ior`: the volume's (g.transmission_ior; 0 for a thin wall) or one colour's.
vec3 refracted_radiance_ior(GBuffer g, vec3 n, vec3 v, float ior) {
    vec3 offset = volume_exit_offset(n, v, TRANSMISSION_THICKNESS, ior);
    vec4 clip = u_projection * (u_view * vec4(v_position_ws + offset, 1.0));
    if (!(clip.w > 1e-6)) {
        clip = u_projection * (u_view * vec4(v_position_ws, 1.0));
    }
    vec2 uv = clamp(clip.xy / clip.w * 0.5 + 0.5, 0.0, 1.0);
    float lod = transmission_lod(g.roughness, ior, u_transmission_log2_width);
    vec3 behind = textureLod(u_transmission_frame, uv, lod).rgb;
    return behind * volume_attenuation(u_attenuation_sigma, length(offset));
}

// USE_DISPERSION (a dispersive volume, KHR_materials_dispersion): as three.js's
// getIBLVolumeRefraction with DISPERSION, each colour channel refracted by its own IOR
// (lib/transmission.glsl dispersion_iors: red least, blue most), read where its own ray leaves
// and attenuated along its own chord: three lookups of the copy in place of one.
vec3 refracted_radiance(GBuffer g, vec3 n, vec3 v) {
#if defined(USE_DISPERSION) && GBUFFER_HAS_DISPERSION
    vec3 iors = dispersion_iors(g.transmission_ior, g.dispersion);
    return vec3(refracted_radiance_ior(g, n, v, iors.r).r,
                refracted_radiance_ior(g, n, v, iors.g).g,
                refracted_radiance_ior(g, n, v, iors.b).b);
#else
    return refracted_radiance_ior(g, n, v, g.transmission_ior);
#endif
}
#endif

GBuffer gbuffer_load(ivec2 pixel) {
    float alpha;
    GBuffer g = mesh_surface(alpha);  // every texture lookup first (derivatives), then discard
#if defined(USE_TRANSMISSION) && defined(USE_THICKNESS_MAP)
    forward_thickness = u_thickness * sample_map(u_thickness_map,
                                                 map_uv(u_thickness_set, u_thickness_uv),
                                                 u_thickness_mirror).g;
#endif
    GBuffer opaque = gbuffer_load_opaque(pixel);
    if (opaque.alpha > 0.0 && !(g.depth < opaque.depth)) {
        discard;  // behind (or at) the opaque surface of this pixel
    }
#if defined(USE_TRANSMISSION) && !defined(ALPHA_BLEND)
#ifdef ALPHA_MASK
    if (alpha < u_alpha_cutoff) {
        discard;
    }
#endif
    alpha = 1.0;  // glTF OPAQUE / MASK: covers the pixel (module comment)
#endif
    g.alpha = clamp(alpha, 0.0, 1.0);
    g.color = g.albedo * g.alpha;  // the unlit colour channel is premultiplied by coverage
    return g;
}
