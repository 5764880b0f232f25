// mesh_surface.glsl - a glTF 2.0 metallic-roughness surface at this fragment: material factors times
// optional maps, vertex colours, emission, the normal (mapped, flipped towards the viewer on back
// faces). Pass-level chunk (uniforms, varyings of passes/gbuffer_mesh.vert), shared by the G-buffer
// fill (gbuffer_mesh.frag, opaque and MASK surfaces) and the forward pass for alphaMode BLEND
// (forward_surface.glsl), so both read a surface identically. The includer declares the GBuffer
// struct first (generated/gbuffer.glsl).
// Defines: USE_BASE_COLOR_MAP, USE_METALLIC_ROUGHNESS_MAP (G = roughness, B = metallic),
// USE_NORMAL_MAP (+ HAS_TANGENTS, else a cotangent frame from derivatives), USE_OCCLUSION_MAP,
// USE_EMISSIVE_MAP; USE_DIELECTRIC (KHR_materials_ior / _specular: the G-buffer's dielectric
// channel from u_ior, u_specular_color, u_specular_factor) with USE_SPECULAR_MAP (A = factor) and
// USE_SPECULAR_COLOR_MAP (linear RGB); USE_CLEARCOAT (KHR_materials_clearcoat: the G-buffer's
// clearcoat channel from u_clearcoat, u_clearcoat_roughness) with USE_CLEARCOAT_MAP (R),
// USE_CLEARCOAT_ROUGHNESS_MAP (G), USE_CLEARCOAT_NORMAL_MAP (the coat's own normal map; without
// it the coat has the interpolated vertex normal); USE_TRANSMISSION (KHR_materials_transmission
// / _volume: the G-buffer's transmission channels from u_transmission, u_transmission_ior) with
// USE_TRANSMISSION_MAP (R; KHR_materials_volume's thickness map, USE_THICKNESS_MAP, is the forward
// pass's: passes/forward_surface.glsl) and USE_DISPERSION (a dispersive volume,
// KHR_materials_dispersion: the G-buffer's dispersion channel from u_dispersion);
// USE_SHEEN (KHR_materials_sheen: the G-buffer's sheen channel from u_sheen_color,
// u_sheen_roughness) with USE_SHEEN_COLOR_MAP (linear RGB) and USE_SHEEN_ROUGHNESS_MAP (A);
// USE_ANISOTROPY (KHR_materials_anisotropy: the G-buffer's anisotropy channel,
// passes/mesh_anisotropy.glsl) with USE_ANISOTROPY_MAP;
// USE_IRIDESCENCE (KHR_materials_iridescence: the G-buffer's iridescence channel from
// u_iridescence) with USE_IRIDESCENCE_MAP (R) and USE_IRIDESCENCE_THICKNESS_MAP (G);
// USE_UV0 / USE_UV1 when a map reads that texture coordinate set;
// USE_VERTEX_COLOR (COLOR_0 multiplies the base colour and alpha; with UNLIT_VERTEX_COLOR, a
// KHR_materials_unlit surface, whose colour the loader made its emission, that emission too).
// Every map is read through sample_map: its coordinate set (u_<map>_set), KHR_texture_transform
// (u_<map>_uv, a 3x3 affine matrix made by viewer.geometry.mesh.TextureSampling.uv_matrix) and,
// per axis, MIRRORED_REPEAT (u_<map>_mirror; REPEAT and CLAMP_TO_EDGE are the sampler's own).
#include "lib/brdf.glsl"
#include "lib/layers.glsl"

uniform vec3 u_albedo;              // linear base colour factor
uniform float u_base_alpha;         // glTF baseColorFactor alpha
uniform float u_roughness;          // perceptual
uniform float u_metallic;
uniform float u_specular;           // f0 = 0.16 s^2
uniform float u_ao;
uniform float u_normal_scale;       // glTF normalTexture.scale
uniform float u_occlusion_strength; // glTF occlusionTexture.strength
uniform vec3 u_emissive;            // linear emitted radiance (emissiveFactor x strength)
#ifdef USE_DIELECTRIC
uniform float u_ior;                // KHR_materials_ior (0: infinite)
uniform vec3 u_specular_color;      // KHR_materials_specular specularColorFactor
uniform float u_specular_factor;    // KHR_materials_specular specularFactor
#endif

#ifdef USE_BASE_COLOR_MAP
uniform sampler2D u_base_color_map;          // linear RGB(A)
uniform int u_base_color_set;
uniform mat3 u_base_color_uv;
uniform vec2 u_base_color_mirror;
#endif
#ifdef USE_METALLIC_ROUGHNESS_MAP
uniform sampler2D u_metallic_roughness_map;  // G = roughness, B = metallic
uniform int u_metallic_roughness_set;
uniform mat3 u_metallic_roughness_uv;
uniform vec2 u_metallic_roughness_mirror;
#endif
#ifdef USE_NORMAL_MAP
uniform sampler2D u_normal_map;              // tangent space, n * 0.5 + 0.5
uniform int u_normal_set;
uniform mat3 u_normal_uv;
uniform vec2 u_normal_mirror;
#endif
#ifdef USE_OCCLUSION_MAP
uniform sampler2D u_occlusion_map;           // R = occlusion
uniform int u_occlusion_set;
uniform mat3 u_occlusion_uv;
uniform vec2 u_occlusion_mirror;
#endif
#ifdef USE_EMISSIVE_MAP
uniform sampler2D u_emissive_map;            // linear RGB
uniform int u_emissive_set;
uniform mat3 u_emissive_uv;
uniform vec2 u_emissive_mirror;
#endif

#ifdef USE_TRANSMISSION
uniform float u_transmission;           // transmissionFactor
uniform float u_transmission_ior;       // the volume's IOR, 0 = thin-walled (Material.volume_ior)
#ifdef USE_DISPERSION
uniform float u_dispersion;             // KHR_materials_dispersion 20 / V_d (a volume's only)
#endif
#endif
#ifdef USE_TRANSMISSION_MAP
uniform sampler2D u_transmission_map;        // R = factor
uniform int u_transmission_set;
uniform mat3 u_transmission_uv;
uniform vec2 u_transmission_mirror;
#endif
#ifdef USE_CLEARCOAT
uniform float u_clearcoat;              // clearcoatFactor
uniform float u_clearcoat_roughness;    // clearcoatRoughnessFactor (perceptual)
uniform float u_clearcoat_normal_scale; // clearcoatNormalTexture.scale
#endif
#ifdef USE_CLEARCOAT_MAP
uniform sampler2D u_clearcoat_map;           // R = factor
uniform int u_clearcoat_set;
uniform mat3 u_clearcoat_uv;
uniform vec2 u_clearcoat_mirror;
#endif
#ifdef USE_CLEARCOAT_ROUGHNESS_MAP
uniform sampler2D u_clearcoat_roughness_map; // G = roughness
uniform int u_clearcoat_roughness_set;
uniform mat3 u_clearcoat_roughness_uv;
uniform vec2 u_clearcoat_roughness_mirror;
#endif
#ifdef USE_CLEARCOAT_NORMAL_MAP
uniform sampler2D u_clearcoat_normal_map;    // tangent space, n * 0.5 + 0.5
uniform int u_clearcoat_normal_set;
uniform mat3 u_clearcoat_normal_uv;
uniform vec2 u_clearcoat_normal_mirror;
#endif
#ifdef USE_SHEEN
uniform vec3 u_sheen_color;             // sheenColorFactor (linear)
uniform float u_sheen_roughness;        // sheenRoughnessFactor
#endif
#ifdef USE_SHEEN_COLOR_MAP
uniform sampler2D u_sheen_color_map;         // linear RGB
uniform int u_sheen_color_set;
uniform mat3 u_sheen_color_uv;
uniform vec2 u_sheen_color_mirror;
#endif
#ifdef USE_SHEEN_ROUGHNESS_MAP
uniform sampler2D u_sheen_roughness_map;     // A = roughness
uniform int u_sheen_roughness_set;
uniform mat3 u_sheen_roughness_uv;
uniform vec2 u_sheen_roughness_mirror;
#endif
#ifdef USE_IRIDESCENCE
uniform vec4 u_iridescence;  // factor, thickness (the maximum, nm), film IOR, the minimum (nm)
#endif
#ifdef USE_IRIDESCENCE_MAP
uniform sampler2D u_iridescence_map;         // R = factor
uniform int u_iridescence_set;
uniform mat3 u_iridescence_uv;
uniform vec2 u_iridescence_mirror;
#endif
#ifdef USE_IRIDESCENCE_THICKNESS_MAP
uniform sampler2D u_iridescence_thickness_map;  // G blends the minimum to the maximum
uniform int u_iridescence_thickness_set;
uniform mat3 u_iridescence_thickness_uv;
uniform vec2 u_iridescence_thickness_mirror;
#endif
#ifdef USE_SPECULAR_MAP
uniform sampler2D u_specular_map;            // A = specular factor
uniform int u_specular_set;
uniform mat3 u_specular_uv;
uniform vec2 u_specular_mirror;
#endif
#ifdef USE_SPECULAR_COLOR_MAP
uniform sampler2D u_specular_color_map;      // linear RGB
uniform int u_specular_color_set;
uniform mat3 u_specular_color_uv;
uniform vec2 u_specular_color_mirror;
#endif

in vec3 v_position_ws;
in vec3 v_normal_ws;
in float v_depth_vs;
#ifdef USE_UV0
in vec2 v_uv0;
#endif
#ifdef USE_UV1
in vec2 v_uv1;
#endif
#ifdef HAS_TANGENTS
in vec4 v_tangent_ws;
#endif
#ifdef USE_VERTEX_COLOR
in vec4 v_color;
#endif

// Texture coordinate set `set` (0 or 1) of this fragment.
vec2 texcoord(int set) {
#if defined(USE_UV0) && defined(USE_UV1)
    return set == 1 ? v_uv1 : v_uv0;
#elif defined(USE_UV1)
    return v_uv1;
#elif defined(USE_UV0)
    return v_uv0;
#else
    return vec2(0.0);
#endif
}

// The coordinates a map is sampled at: set `set` through the KHR_texture_transform matrix.
vec2 map_uv(int set, mat3 uv_transform) {
    return (uv_transform * vec3(texcoord(set), 1.0)).xy;
}

// glTF sampler wrap MIRRORED_REPEAT on the axes where mirror = 1 (the sampler clamps to the edge
// there, so the edge texel repeats at each mirror seam as GL's own mode does); the derivatives of
// the unwrapped coordinates choose the mip level, so the seams get no spurious coarse lookups.
// Without a mirrored axis (a uniform: the branch is the same for every pixel) the implicit
// derivatives are those same ones, and plain texture() reads them: llvmpipe mis-reads
// textureGrad under anisotropic filtering (viewer/passes/mesh_uploads.py ANISOTROPY).
vec4 sample_map(sampler2D map, vec2 uv, vec2 mirror) {
    if (mirror == vec2(0.0)) {
        return texture(map, uv);
    }
    vec2 mirrored = 1.0 - abs(mod(uv, 2.0) - 1.0);
    return textureGrad(map, mix(uv, mirrored, mirror), dFdx(uv), dFdy(uv));
}

#if defined(USE_NORMAL_MAP) || defined(USE_CLEARCOAT_NORMAL_MAP)
// Normal Mapping Without Precomputed Tangents - Schueler 2013 (cotangent frame from derivatives).
// n_face must face the viewer so the frame's handedness is the surface's own. Returns the
// gradients of u and of -v (glTF: the normal map's +Y points towards decreasing v), each scaled
// by the same factor, and n_face.
mat3 cotangent_frame(vec3 n_face, vec3 p, vec2 uv) {
    vec3 dp1 = dFdx(p);
    vec3 dp2 = dFdy(p);
    vec2 duv1 = dFdx(uv);
    vec2 duv2 = dFdy(uv);
    vec3 dp2perp = cross(dp2, n_face);
    vec3 dp1perp = cross(n_face, dp1);
    vec3 t = dp2perp * duv1.x + dp1perp * duv2.x;
    vec3 b = dp2perp * duv1.y + dp1perp * duv2.y;
    float invmax = inversesqrt(max(max(dot(t, t), dot(b, b)), 1e-30));
    return mat3(t * invmax, -b * invmax, n_face);
}

// The unit normal n (interpolated, front face's) tilted by the tangent-space normal n_ts read at
// uv: the vertex tangents' frame (HAS_TANGENTS), else the cotangent frame, which is intrinsic
// (it depends on the uv layout, not on the facing: the result is flipped for back faces by the
// caller like the unmapped normal). `facing`: +1 front face, -1 back face.
vec3 perturb_normal(vec3 n, vec3 n_ts, vec2 uv, float facing) {
#ifdef HAS_TANGENTS
    vec3 t = v_tangent_ws.xyz - n * dot(n, v_tangent_ws.xyz);
    t = dot(t, t) > 1e-20 ? normalize(t) : vec3(0.0);
    vec3 b = cross(n, t) * (v_tangent_ws.w < 0.0 ? -1.0 : 1.0);
    return normalize(t * n_ts.x + b * n_ts.y + n * n_ts.z);
#else
    mat3 tbn = cotangent_frame(n * facing, v_position_ws, uv);
    return normalize(tbn[0] * n_ts.x + tbn[1] * n_ts.y + n * n_ts.z);
#endif
}
#endif
#include "passes/mesh_anisotropy.glsl"

// The surface at this fragment as a G-buffer record (coverage 1, view depth, the unlit colour =
// albedo) and, in `alpha`, the glTF alpha: baseColorFactor.a x base colour texture alpha x COLOR_0
// alpha. Every texture lookup happens here, before any caller discards (derivatives are only
// defined while all fragments of a quad run).
GBuffer mesh_surface(out float alpha) {
    vec3 n = normalize(v_normal_ws);
    // back faces of double-sided materials: the normal is flipped towards the viewer (single-sided
    // ones never get here: the G-buffer and forward passes cull them)
    float facing = gl_FrontFacing ? 1.0 : -1.0;

    GBuffer g = gbuffer_background();
    g.albedo = u_albedo;
    alpha = u_base_alpha;
    g.roughness = u_roughness;
    g.metallic = u_metallic;
    g.specular = u_specular;
    g.ao = u_ao;
#ifdef USE_BASE_COLOR_MAP
    vec4 base = sample_map(u_base_color_map, map_uv(u_base_color_set, u_base_color_uv),
                           u_base_color_mirror);
    g.albedo *= base.rgb;
    alpha *= base.a;
#endif
#ifdef USE_VERTEX_COLOR
    g.albedo *= v_color.rgb;
    alpha *= v_color.a;
#endif
#ifdef USE_METALLIC_ROUGHNESS_MAP
    vec4 mr = sample_map(u_metallic_roughness_map,
                         map_uv(u_metallic_roughness_set, u_metallic_roughness_uv),
                         u_metallic_roughness_mirror);
    g.roughness *= mr.g;
    g.metallic *= mr.b;
#endif
#ifdef USE_OCCLUSION_MAP
    float occlusion = sample_map(u_occlusion_map, map_uv(u_occlusion_set, u_occlusion_uv),
                                 u_occlusion_mirror).r;
    g.ao *= 1.0 + u_occlusion_strength * (occlusion - 1.0);
#endif
#ifdef USE_NORMAL_MAP
    vec2 normal_uv = map_uv(u_normal_set, u_normal_uv);
    vec3 n_ts = sample_map(u_normal_map, normal_uv, u_normal_mirror).xyz * 2.0 - 1.0;
    n_ts.xy *= u_normal_scale;
    n = perturb_normal(n, n_ts, normal_uv, facing);  // flipped below for back faces
#endif
    g.emission = u_emissive;
#ifdef USE_EMISSIVE_MAP
    g.emission *= sample_map(u_emissive_map, map_uv(u_emissive_set, u_emissive_uv),
                             u_emissive_mirror).rgb;
#endif
#ifdef USE_DIELECTRIC
    vec3 specular_color = u_specular_color;
    float specular_factor = u_specular_factor;
#ifdef USE_SPECULAR_COLOR_MAP
    specular_color *= sample_map(u_specular_color_map,
                                 map_uv(u_specular_color_set, u_specular_color_uv),
                                 u_specular_color_mirror).rgb;
#endif
#ifdef USE_SPECULAR_MAP
    specular_factor *= sample_map(u_specular_map, map_uv(u_specular_set, u_specular_uv),
                                  u_specular_mirror).a;
#endif
    g.dielectric = vec4(dielectric_f0_ior(u_ior, specular_color, specular_factor),
                        specular_factor);
#endif
#if defined(USE_VERTEX_COLOR) && defined(UNLIT_VERTEX_COLOR)
    g.emission *= v_color.rgb;
#endif
#ifdef USE_CLEARCOAT
    // the coat: its own factor, roughness and normal (the vertex normal, or its own map's)
    vec3 n_coat = normalize(v_normal_ws);
#ifdef USE_CLEARCOAT_NORMAL_MAP
    vec2 coat_uv = map_uv(u_clearcoat_normal_set, u_clearcoat_normal_uv);
    vec3 c_ts = sample_map(u_clearcoat_normal_map, coat_uv, u_clearcoat_normal_mirror).xyz * 2.0
                - 1.0;
    c_ts.xy *= u_clearcoat_normal_scale;
    n_coat = perturb_normal(n_coat, c_ts, coat_uv, facing);
#endif
    float coat = u_clearcoat;
    float coat_roughness = u_clearcoat_roughness;
#ifdef USE_CLEARCOAT_MAP
    coat *= sample_map(u_clearcoat_map, map_uv(u_clearcoat_set, u_clearcoat_uv),
                       u_clearcoat_mirror).r;
#endif
#ifdef USE_CLEARCOAT_ROUGHNESS_MAP
    coat_roughness *= sample_map(u_clearcoat_roughness_map,
                                 map_uv(u_clearcoat_roughness_set, u_clearcoat_roughness_uv),
                                 u_clearcoat_roughness_mirror).g;
#endif
    g.clearcoat = vec4(coat, coat_roughness, oct_encode(n_coat * facing));
#endif
#ifdef USE_TRANSMISSION
    g.transmission = u_transmission;
#ifdef USE_TRANSMISSION_MAP
    g.transmission *= sample_map(u_transmission_map, map_uv(u_transmission_set, u_transmission_uv),
                                 u_transmission_mirror).r;
#endif
    g.transmission_ior = u_transmission_ior;
#endif
#if defined(USE_DISPERSION) && GBUFFER_HAS_DISPERSION
    g.dispersion = u_dispersion;
#endif
#ifdef USE_SHEEN
    vec3 sheen_color = u_sheen_color;
    float sheen_roughness = u_sheen_roughness;
#ifdef USE_SHEEN_COLOR_MAP
    sheen_color *= sample_map(u_sheen_color_map, map_uv(u_sheen_color_set, u_sheen_color_uv),
                              u_sheen_color_mirror).rgb;
#endif
#ifdef USE_SHEEN_ROUGHNESS_MAP
    sheen_roughness *= sample_map(u_sheen_roughness_map,
                                  map_uv(u_sheen_roughness_set, u_sheen_roughness_uv),
                                  u_sheen_roughness_mirror).a;
#endif
#if GBUFFER_HAS_SHEEN  // (a layout without the channel has no field for it)
    g.sheen = vec4(sheen_color, sheen_roughness);
#endif
#endif
#if defined(USE_ANISOTROPY) && GBUFFER_HAS_ANISOTROPY
    g.anisotropy = mesh_anisotropy(n, normalize(v_normal_ws), facing);
#endif
#if defined(USE_IRIDESCENCE) && GBUFFER_HAS_IRIDESCENCE
    // (the all-features layout has no iridescence channel: GL's 8 draw buffers are full)
    vec3 film = u_iridescence.xyz;
#ifdef USE_IRIDESCENCE_MAP
    film.x *= sample_map(u_iridescence_map, map_uv(u_iridescence_set, u_iridescence_uv),
                         u_iridescence_mirror).r;
#endif
#ifdef USE_IRIDESCENCE_THICKNESS_MAP
    film.y = mix(u_iridescence.w, u_iridescence.y,
                 sample_map(u_iridescence_thickness_map,
                            map_uv(u_iridescence_thickness_set, u_iridescence_thickness_uv),
                            u_iridescence_thickness_mirror).g);
#endif
    g.iridescence = film;
#endif
    g.normal = n * facing;  // back faces: flip towards the viewer
    g.alpha = 1.0;
    g.depth = v_depth_vs;
    g.color = g.albedo;  // a mesh's unlit colour is its albedo (premultiplied by alpha = 1)
    return g;
}
