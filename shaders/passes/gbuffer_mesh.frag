// gbuffer_mesh.frag - G-buffer fill for triangle meshes: material factors times optional maps.
// Defines: USE_BASE_COLOR_MAP, USE_METALLIC_ROUGHNESS_MAP (G = roughness, B = metallic),
// USE_NORMAL_MAP (+ HAS_TANGENTS, else a cotangent frame from derivatives), USE_OCCLUSION_MAP;
// USE_UV is set whenever any map is.
#define GBUFFER_WRITE
#include "generated/gbuffer.glsl"

uniform vec3 u_albedo;              // linear base colour factor
uniform float u_roughness;          // perceptual
uniform float u_metallic;
uniform float u_specular;           // f0 = 0.16 s^2
uniform float u_ao;
uniform float u_normal_scale;       // glTF normalTexture.scale
uniform float u_occlusion_strength; // glTF occlusionTexture.strength

#ifdef USE_BASE_COLOR_MAP
uniform sampler2D u_base_color_map;          // linear RGB(A)
#endif
#ifdef USE_METALLIC_ROUGHNESS_MAP
uniform sampler2D u_metallic_roughness_map;  // G = roughness, B = metallic
#endif
#ifdef USE_NORMAL_MAP
uniform sampler2D u_normal_map;              // tangent space, n * 0.5 + 0.5
#endif
#ifdef USE_OCCLUSION_MAP
uniform sampler2D u_occlusion_map;           // R = occlusion
#endif

in vec3 v_position_ws;
in vec3 v_normal_ws;
in float v_depth_vs;
#ifdef USE_UV
in vec2 v_uv;
#endif
#ifdef HAS_TANGENTS
in vec4 v_tangent_ws;
#endif

#ifdef USE_NORMAL_MAP
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
#endif

void main() {
    vec3 n = normalize(v_normal_ws);
    float facing = gl_FrontFacing ? 1.0 : -1.0;

    GBuffer g = gbuffer_background();
    g.albedo = u_albedo;
    g.roughness = u_roughness;
    g.metallic = u_metallic;
    g.specular = u_specular;
    g.ao = u_ao;
#ifdef USE_BASE_COLOR_MAP
    g.albedo *= texture(u_base_color_map, v_uv).rgb;
#endif
#ifdef USE_METALLIC_ROUGHNESS_MAP
    vec4 mr = texture(u_metallic_roughness_map, v_uv);
    g.roughness *= mr.g;
    g.metallic *= mr.b;
#endif
#ifdef USE_OCCLUSION_MAP
    g.ao *= 1.0 + u_occlusion_strength * (texture(u_occlusion_map, v_uv).r - 1.0);
#endif
#ifdef USE_NORMAL_MAP
    vec3 n_ts = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;
    n_ts.xy *= u_normal_scale;
#ifdef HAS_TANGENTS
    vec3 t = v_tangent_ws.xyz - n * dot(n, v_tangent_ws.xyz);
    t = dot(t, t) > 1e-20 ? normalize(t) : vec3(0.0);
    vec3 b = cross(n, t) * (v_tangent_ws.w < 0.0 ? -1.0 : 1.0);
    n = normalize(t * n_ts.x + b * n_ts.y + n * n_ts.z);
#else
    // The frame is intrinsic (it depends on the uv layout, not on the facing); the perturbed
    // normal is flipped below for back faces like the unmapped one.
    mat3 tbn = cotangent_frame(n * facing, v_position_ws, v_uv);
    n = normalize(tbn[0] * n_ts.x + tbn[1] * n_ts.y + n * n_ts.z);
#endif
#endif
    g.normal = n * facing;  // back faces: flip towards the viewer
    g.alpha = 1.0;
    g.depth = v_depth_vs;
    g.color = g.albedo;  // a mesh's unlit colour is its albedo (premultiplied by alpha = 1)
    gbuffer_store(g);
}
