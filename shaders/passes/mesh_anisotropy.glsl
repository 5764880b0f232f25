// mesh_anisotropy.glsl (pass chunk) - KHR_materials_anisotropy at a mesh fragment: the G-buffer's
// `anisotropy` channel from u_anisotropy_strength, u_anisotropy_rotation and, with
// USE_ANISOTROPY_MAP, the map (RG: the direction in tangent space, x 2 - 1; B: times the
// strength). Included by passes/mesh_surface.glsl after sample_map and map_uv; compiled only
// with USE_ANISOTROPY (the library is included either way: the include resolver includes a file
// once, whatever #if surrounds it, so a program that shades several meshes - the forward pass -
// must not meet it first inside a false branch). The tangent space: the vertex tangents
// (HAS_TANGENTS; bitangent cross(n, t) w), else the UV frame of texture coordinate set
// u_anisotropy_frame_set (USE_UV0 / USE_UV1; the spec's computed tangents): T along dp/du,
// B = cross(n, T) on the side of -dp/dv, both unit (mesh_uv_frame; as raytrace.glsl
// rt_anisotropy and the reference's dp/du), else - a mesh without tangents or texture
// coordinates, which the spec does not allow - tangent_to_world's frame of the normal (the
// loader warns).
#include "lib/anisotropy.glsl"
#ifdef USE_ANISOTROPY

uniform float u_anisotropy_strength;   // anisotropyStrength
uniform vec2 u_anisotropy_rotation;    // (cos, sin) of anisotropyRotation
uniform int u_anisotropy_frame_set;    // the texture coordinate set of the tangent space
#ifdef USE_ANISOTROPY_MAP
uniform sampler2D u_anisotropy_map;    // RG: direction (x 2 - 1), B: strength; linear
uniform int u_anisotropy_set;
uniform mat3 u_anisotropy_uv;
uniform vec2 u_anisotropy_mirror;
#endif

#if !defined(HAS_TANGENTS) && (defined(USE_UV0) || defined(USE_UV1))
// (T, B) of the surface of unit normal n at this fragment from the screen derivatives of the
// position and of uv: dp/du solved from dp = dp/du du + dp/dv dv along x and y, put into n's
// plane; B = cross(n, T) turned towards -dp/dv (glTF's +Y: decreasing v).
mat2x3 mesh_uv_frame(vec3 n, vec3 p, vec2 uv) {
    vec3 dpx = dFdx(p);
    vec3 dpy = dFdy(p);
    vec2 dux = dFdx(uv);
    vec2 duy = dFdy(uv);
    float det = dux.x * duy.y - dux.y * duy.x;
    vec3 dpdu = (dpx * duy.y - dpy * dux.y) * det;  // times det^2: the same directions
    vec3 dpdv = (dpy * dux.x - dpx * duy.x) * det;
    vec3 t = dpdu - n * dot(n, dpdu);
    t = dot(t, t) > 1e-30 ? normalize(t) : tangent_to_world(vec3(1.0, 0.0, 0.0), n);
    vec3 b = cross(n, t);
    return mat2x3(t, dot(b, dpdv) > 0.0 ? -b : b);
}
#endif

// The channel's value for the shading normal n (front face's, unit; normal-mapped where the
// material has a normal map) and the interpolated vertex normal n_vertex, on a face of `facing`
// (+1 front, -1 back: the G-buffer stores n facing).
vec2 mesh_anisotropy(vec3 n, vec3 n_vertex, float facing) {
    float strength = u_anisotropy_strength;
    vec2 c = u_anisotropy_rotation;
    vec2 direction = c;
#ifdef USE_ANISOTROPY_MAP
    vec3 mapped = anisotropy_map_direction(c, sample_map(u_anisotropy_map,
        map_uv(u_anisotropy_set, u_anisotropy_uv), u_anisotropy_mirror).rgb);
    direction = mapped.xy;  // turned counter-clockwise by the rotation
    strength *= mapped.z;
#endif
#if defined(HAS_TANGENTS)
    vec3 t = v_tangent_ws.xyz - n_vertex * dot(n_vertex, v_tangent_ws.xyz);
    t = dot(t, t) > 1e-20 ? normalize(t) : tangent_to_world(vec3(1.0, 0.0, 0.0), n_vertex);
    vec3 b = cross(n_vertex, t) * (v_tangent_ws.w < 0.0 ? -1.0 : 1.0);
#elif defined(USE_UV0) || defined(USE_UV1)
    mat2x3 tb = mesh_uv_frame(n_vertex, v_position_ws, texcoord(u_anisotropy_frame_set));
    vec3 t = tb[0];
    vec3 b = tb[1];
#else
    vec3 t = tangent_to_world(vec3(1.0, 0.0, 0.0), n_vertex);
    vec3 b = tangent_to_world(vec3(0.0, 1.0, 0.0), n_vertex);
#endif
    vec3 ta = t * direction.x + b * direction.y;
    ta -= n * dot(n, ta);  // into the (mapped) shading normal's plane
    if (!(dot(ta, ta) > 1e-20)) return vec2(0.0);
    return anisotropy_encode(normalize(ta), n * facing, strength);
}
#endif
