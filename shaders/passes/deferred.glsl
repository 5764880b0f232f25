// deferred.glsl - the shared part of every lighting pass (shade_*.frag): G-buffer access, the
// per-pixel view ray, the environment's rotation and intensity, the background, ambient occlusion,
// and the surface's own emission.
// Pass-level chunk (has uniforms); the shading maths lives in shaders/lib.
#define GBUFFER_READ
#ifndef SPECULAR_LOBE
#define SPECULAR_LOBE 1  // 0 when no surface of the scene has f0 > 0 (viewer/specialize.py)
#endif
#include "generated/gbuffer.glsl"
#ifndef FORWARD_TRANSMISSION
#define FORWARD_TRANSMISSION 0  // 1: a transmissive surface in the forward pass (forward_surface)
#endif
#include "lib/common.glsl"
#include "lib/equirect.glsl"

uniform mat3 u_camera_to_world;  // columns: camera right, up, back (+Z of view space), world space
uniform vec2 u_tan_half_fov;     // (tan(fov_x / 2), tan(fov_y / 2))
uniform vec2 u_resolution;       // framebuffer size in pixels
uniform float u_env_intensity;   // environment radiance scale
uniform float u_env_rotation;    // radians about +Y, counter-clockwise seen from above
uniform sampler2D u_env_radiance;

in vec2 v_uv;
layout(location = 0) out vec4 o_radiance;  // linear radiance (rgb), coverage (a)

// Unit direction from the camera through the pixel centre at gl_FragCoord.xy, world space.
vec3 view_ray_ws(vec2 frag_coord) {
    vec2 ndc = frag_coord / u_resolution * 2.0 - 1.0;
    return normalize(u_camera_to_world * vec3(ndc * u_tan_half_fov, -1.0));
}

// World direction -> the environment's own frame (the environment is rotated by u_env_rotation).
vec3 env_dir(vec3 d_ws) {
    return rotate_y(d_ws, -u_env_rotation);
}

vec3 background_radiance(vec3 d_ws) {
#if BACKGROUND_ENVIRONMENT
    return textureLod(u_env_radiance, equirect_uv(env_dir(d_ws)), 0.0).rgb * u_env_intensity;
#else
    return vec3(0.0);
#endif
}

// ---- ambient occlusion (the diffuse term of every model; SPECULAR_OCCLUSION) ------------------
// USE_AO: the G-buffer's baked ao channel; USE_SSAO: screen-space occlusion from passes/ssao.frag
// (thesis eq. 6.19), texture u_ssao (r = visibility O(x); g = the environment's visibility S(x)
// where SSAO_ENV_VIS computed it). Both multiply diffuse light only. SSAO_SHADOW_NET: u_ssao is
// the neural shadow estimator's per-colour visibility V instead ([render] shadow_net_use =
// "visibility", viewer/graph/shadow_net.py), whose mean stands for both O(x) and S(x).
#ifndef USE_AO
#define USE_AO 0
#endif
#ifndef USE_SSAO
#define USE_SSAO 0
#endif
#ifndef SSAO_SHADOW_NET
#define SSAO_SHADOW_NET 0
#endif
// SPECULAR_OCCLUSION: the same occlusion also takes its share of the environment's specular
// light (lib/shading.glsl specular_occlusion; [render] specular_occlusion), in the models whose
// specular light is the prefiltered environment (ggx_split_sum, neural)
#ifndef SPECULAR_OCCLUSION
#define SPECULAR_OCCLUSION 0
#endif
#if USE_SSAO
uniform sampler2D u_ssao;

// O(x) (channel 0) or S(x) (channel 1) at ``pixel``
float ssao_channel(ivec2 pixel, int channel) {
    vec4 t = texelFetch(u_ssao, pixel, 0);
#if SSAO_SHADOW_NET
    return (t.r + t.g + t.b) / 3.0;
#else
    return channel == 0 ? t.r : t.g;
#endif
}
#endif

float ambient_occlusion(ivec2 pixel, GBuffer g) {
    float ao = USE_AO != 0 ? g.ao : 1.0;
#if USE_SSAO
    ao *= ssao_channel(pixel, 0);
#endif
    return ao;
}

// The scene's punctual lights (LIGHT_COUNT, LIGHT_POSITIONAL): passes/lights.glsl, included by
// each lighting pass after lib/shading.glsl.

// ---- emission (glTF emissive; the G-buffer's optional channel, 0 where a scene has none) --------
// Radiance the surface emits towards the viewer, added to every model's reflected radiance. It
// lights nothing else: the rasteriser has no paths from one surface to another.
vec3 emitted_radiance(GBuffer g) {
    return g.emission;
}

// the shadow-catcher ground (ground_catcher): passes/ground.glsl
#include "passes/ground.glsl"

// Composite a shaded surface of coverage alpha over the background and write it.
void write_radiance(vec3 shaded, vec3 background, float alpha) {
    shaded = ground_catcher(shaded, background);
    o_radiance = vec4(mix(background, shaded, alpha), alpha);
}
