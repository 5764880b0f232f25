// raytrace.glsl (pass chunk) - rays against the scene's triangles: the BVH and triangle buffers
// viewer/raytrace uploads (viewer/raytrace/scene.py says what they hold), its traversal (closest
// hit, any hit), alpha-masked surfaces, splats' Gaussians inside their proxies, and the surface a
// ray hits. The pure maths is
// lib/bvh.glsl. Buffers bind at 3 .. 5 (viewer/raytrace/upload.py BINDINGS); the nodes, the
// triangles' edges and the splats are textures (upload.py says why).
#include "lib/bvh.glsl"
// dielectric_f0_ior (the specular maps), anisotropy_map_direction: included whatever the scene
// (the resolver includes a file once, even inside a false #if)
#include "lib/brdf.glsl"
#include "lib/anisotropy.glsl"
#ifndef RAYTRACE_STACK
#define RAYTRACE_STACK 42  // viewer.raytrace.bvh.MAX_DEPTH + 2: the deepest path's far children
#endif

layout(std430, binding = 3) readonly buffer RaytraceTriangles { uvec4 rt_triangles[]; };
layout(std430, binding = 4) readonly buffer RaytraceVertices { vec4 rt_vertices[]; }; // 2 a vertex
layout(std430, binding = 5) readonly buffer RaytraceMaterials { vec4 rt_materials[]; }; // RT_MATERIAL_ROWS each
#define RT_TEXEL_ROW_LOG2 12  // texels a row of u_rt_nodes and u_rt_edges: upload.py TEXEL_ROW
// 4 texels an interior node: its children's (lo, ref), (hi, count) (viewer/raytrace/bvh.py
// child_pairs)
uniform sampler2D u_rt_nodes;
// 3 texels a triangle: p0, p1 - p0, p2 - p0 (xyz); the first's w: 1 + the splat a splat proxy's
// face belongs to (viewer/raytrace/splat_proxies.py), 0 for any other triangle
uniform sampler2D u_rt_edges;
// 4 texels a splat (viewer/raytrace/splat_proxies.py splat_rows): its unit-Gaussian frame's
// affine map (rows: W_i, c_i), then (opacity, core radius^2)
uniform sampler2D u_rt_splats;
uniform sampler2DArray u_rt_maps;  // every traced map, one layer each (MAP_SIZE^2, linear)
uniform int u_rt_node_count;       // 0: the scene has no triangles (every ray misses)

// A material's rows (viewer/raytrace/scene.py ROW, material_rows): the factors, then the map
// slots, two rows each (KHR_texture_transform's two rows; the layer in row 0's w, -1: none; the
// wrap modes in row 1's w).
#define RT_ROW_BASE 0          // base colour factor (rgb), its alpha
#define RT_ROW_SURFACE 1       // roughness, metallic, specular, MASK cutoff (-1: not masked)
#define RT_ROW_EMISSION 2      // emissive (rgb), double-sided
#define RT_ROW_DIELECTRIC 3    // KHR_materials_ior / _specular: F0 (rgb), F90 (a < 0: none)
#define RT_ROW_CLEARCOAT 4     // KHR_materials_clearcoat: factor, roughness
#define RT_ROW_TRANSMISSION 5  // KHR_materials_transmission: factor, the volume's IOR
#define RT_ROW_VOLUME 6        // KHR_materials_volume: sigma (rgb)
#define RT_ROW_SHEEN 7         // KHR_materials_sheen: colour (rgb), roughness
#define RT_ROW_ANISOTROPY 8    // KHR_materials_anisotropy: strength, (cos, sin) of the rotation
#define RT_ROW_IRIDESCENCE 9   // KHR_materials_iridescence: factor, max thickness, IOR, min
#define RT_ROW_SPECULAR 10     // KHR_materials_specular's colour factor (rgb), KHR_materials_ior
#define RT_ROW_SLOTS 11
// The map-slot table (viewer/raytrace/scene.py MAP_SLOTS, the same order): slot k is rows
// RT_ROW_SLOTS + 2k and + 1 of a material.
#define RT_MAP_BASE_COLOR 0
#define RT_MAP_METALLIC_ROUGHNESS 1
#define RT_MAP_EMISSIVE 2
#define RT_MAP_SPECULAR 3
#define RT_MAP_SPECULAR_COLOR 4
#define RT_MAP_CLEARCOAT 5
#define RT_MAP_CLEARCOAT_ROUGHNESS 6
#define RT_MAP_SHEEN_COLOR 7
#define RT_MAP_SHEEN_ROUGHNESS 8
#define RT_MAP_ANISOTROPY 9
#define RT_MAP_IRIDESCENCE 10
#define RT_MAP_IRIDESCENCE_THICKNESS 11
#define RT_MAP_TRANSMISSION 12
#define RT_MAP_SLOTS 13
#define RT_MATERIAL_ROWS (RT_ROW_SLOTS + 2 * RT_MAP_SLOTS)
// What the scene's traced materials use (viewer/raytrace/upload.py TraceBuffers.defines; a pass
// that does not say assumes everything): llvmpipe runs both sides of a branch for its 8 lanes,
// so a mask test or a map lookup no material needs costs its full price at every call unless
// it is compiled out.
#ifndef RT_MASKS
#define RT_MASKS 1     // whether some material is alphaMode MASK (rt_solid reads them)
#endif
#ifndef RT_MAPS
#define RT_MAPS 8191   // the map slots some material has a map in: bit k for slot k
#endif
#ifndef RT_SPLATS
#define RT_SPLATS 1    // whether some mesh is a splat proxy (its faces' splats are evaluated)
#endif

struct RayHit {
    float t;        // distance along the (unit) ray; t_max where nothing was hit
    int triangle;   // index into rt_triangles, -1 for a miss
    vec2 b;         // barycentric weights of the triangle's 2nd and 3rd vertices
};

vec3 rt_position(uint v) { return rt_vertices[2u * v].xyz; }

// Texel i of u_rt_nodes or u_rt_edges.
vec4 rt_texel(sampler2D s, int i) {
    return texelFetch(s, ivec2(i & ((1 << RT_TEXEL_ROW_LOG2) - 1), i >> RT_TEXEL_ROW_LOG2), 0);
}

// A traced map's coordinate: u, v through the map's KHR_texture_transform rows and its wrap
// modes (code = wrap_s + 3 wrap_t: 0 repeat, 1 clamp, 2 mirrored repeat).
vec2 rt_map_uv(vec2 uv, vec4 row0, vec4 row1) {
    vec2 t = vec2(dot(row0.xyz, vec3(uv, 1.0)), dot(row1.xyz, vec3(uv, 1.0)));
    int code = int(row1.w + 0.5);
    ivec2 w = ivec2(code % 3, code / 3);
    vec2 rep = fract(t);
    vec2 mir = 1.0 - abs(mod(t, 2.0) - 1.0);
    vec2 cl = clamp(t, 0.0, 1.0);
    return vec2(w.x == 0 ? rep.x : (w.x == 1 ? cl.x : mir.x),
                w.y == 0 ? rep.y : (w.y == 1 ? cl.y : mir.y));
}

// Whether material m has a map in slot k (RT_MAP_*).
bool rt_has_map(int m, int k) {
    if (((RT_MAPS >> k) & 1) == 0) return false;
    return rt_materials[m * RT_MATERIAL_ROWS + RT_ROW_SLOTS + 2 * k].w >= 0.0;
}

// The map in slot k (RT_MAP_*) of material m at texture coordinate uv; `fallback` where the
// material has none.
vec4 rt_map(int m, int k, vec2 uv, vec4 fallback) {
    if (((RT_MAPS >> k) & 1) == 0) return fallback;
    vec4 row0 = rt_materials[m * RT_MATERIAL_ROWS + RT_ROW_SLOTS + 2 * k];
    vec4 row1 = rt_materials[m * RT_MATERIAL_ROWS + RT_ROW_SLOTS + 2 * k + 1];
    if (row0.w < 0.0) return fallback;
    return textureLod(u_rt_maps, vec3(rt_map_uv(uv, row0, row1), row0.w), 0.0);
}

vec2 rt_uv(uvec4 tri, vec2 b) {
    vec2 t0 = vec2(rt_vertices[2u * tri.x].w, rt_vertices[2u * tri.x + 1u].w);
    vec2 t1 = vec2(rt_vertices[2u * tri.y].w, rt_vertices[2u * tri.y + 1u].w);
    vec2 t2 = vec2(rt_vertices[2u * tri.z].w, rt_vertices[2u * tri.z + 1u].w);
    return t0 * (1.0 - b.x - b.y) + t1 * b.x + t2 * b.y;
}

// Whether the triangle `tri` is solid at barycentrics b: alphaMode MASK cuts it where the base
// colour's alpha (factor x map) is below the cutoff; every other surface is solid (a splat
// proxy is not a surface: rt_entered_splat).
bool rt_solid(uvec4 tri, vec2 b) {
#if !RT_MASKS
    return true;
#endif
    int m = int(tri.w);
    float cutoff = rt_materials[m * RT_MATERIAL_ROWS + RT_ROW_SURFACE].w;
    if (cutoff < 0.0) return true;
    float alpha = rt_materials[m * RT_MATERIAL_ROWS + RT_ROW_BASE].w
                  * rt_map(m, RT_MAP_BASE_COLOR, rt_uv(tri, b), vec4(1.0)).a;
    return alpha >= cutoff;
}

// The splat whose proxy the triangle with edge texels e0, e1, e2 is a face of, entered through it
// along d (its outward, counter-clockwise face looks against d), or -1: not a splat's proxy, or
// left through this face. A proxy counts only where a ray enters it (one face a splat; a ray
// that starts inside leaves it unhindered).
int rt_entered_splat(vec4 e0, vec4 e1, vec4 e2, vec3 d) {
#if !RT_SPLATS
    return -1;
#endif
    if (e0.w < 0.5) return -1;
    return dot(cross(e1.xyz, e2.xyz), d) < 0.0 ? int(e0.w) - 1 : -2;
}

// The ray o + t d in splat s's unit-Gaussian frame: (o', d').
void rt_splat_ray(int s, vec3 o, vec3 d, out vec3 oc, out vec3 dc) {
    vec4 r0 = rt_texel(u_rt_splats, 4 * s), r1 = rt_texel(u_rt_splats, 4 * s + 1);
    vec4 r2 = rt_texel(u_rt_splats, 4 * s + 2);
    oc = vec3(dot(r0.xyz, o) + r0.w, dot(r1.xyz, o) + r1.w, dot(r2.xyz, o) + r2.w);
    dc = vec3(dot(r0.xyz, d), dot(r1.xyz, d), dot(r2.xyz, d));
}

// Where the ray o + t d (unit d) stops at splat s: the entry into its opaque core (lib/bvh.glsl
// ellipsoid_entry), or -1 where it passes outside the core or the splat has none.
float rt_splat_t(int s, vec3 o, vec3 d) {
    vec3 oc, dc;
    rt_splat_ray(s, o, d, oc, dc);
    return ellipsoid_entry(oc, dc, rt_texel(u_rt_splats, 4 * s + 3).y);
}

// The fraction of light splat s lets through along o + t d, 0 < t < t_max: 1 - opacity
// exp(-q^2 / 2) at the peak along the segment (lib/bvh.glsl gaussian_ray_peak).
float rt_splat_transmittance(int s, vec3 o, vec3 d, float t_max) {
    vec3 oc, dc;
    rt_splat_ray(s, o, d, oc, dc);
    vec2 peak = gaussian_ray_peak(oc, dc, t_max);
    return 1.0 - rt_texel(u_rt_splats, 4 * s + 3).x * exp(-0.5 * peak.y);
}

// Triangle i's edge texels (rt_edges: p0, p1 - p0, p2 - p0; three reads, where the vertices
// took four, one after the other), for ray_triangle_edges and rt_entered_splat.
void rt_edges(int i, out vec4 e0, out vec4 e1, out vec4 e2) {
    e0 = rt_texel(u_rt_edges, 3 * i);
    e1 = rt_texel(u_rt_edges, 3 * i + 1);
    e2 = rt_texel(u_rt_edges, 3 * i + 2);
}

// The traversal walks child entries (viewer/raytrace/bvh.py child_pairs): (ref, count) is an
// interior node's row (count 0) or a leaf's triangles; a node's visit tests its two children's
// boxes, goes to the nearer one it enters and stacks the other. The root's own box is not tested:
// a ray that misses it misses both children (each inside it; the slab test is monotone).

// The nearest solid triangle the ray o + t d (d unit) hits for 0 < t < t_max.
RayHit bvh_closest_hit(vec3 o, vec3 d, float t_max) {
    RayHit hit;
    hit.t = t_max;
    hit.triangle = -1;
    hit.b = vec2(0.0);
    if (u_rt_node_count == 0) return hit;
    vec3 inv_d = safe_inverse(d);
    int stack[RAYTRACE_STACK];
    int stack_count[RAYTRACE_STACK];
    float stack_t[RAYTRACE_STACK];
    int sp = 0;
    int ref = 0;
    int count = 0;
    for (;;) {
        if (count > 0) {
            for (int i = ref; i < ref + count; ++i) {
                vec4 e0, e1, e2;
                rt_edges(i, e0, e1, e2);
                vec3 r = ray_triangle_edges(o, d, e0.xyz, e1.xyz, e2.xyz);
                if (!(r.x > 0.0 && r.x < hit.t)) continue;
                int s = rt_entered_splat(e0, e1, e2, d);
                if (s >= 0) {  // a splat: where the ray enters its opaque core
                    r.x = rt_splat_t(s, o, d);
                    if (!(r.x > 0.0 && r.x < hit.t)) continue;
                } else if (s == -2 || !rt_solid(rt_triangles[i], r.yz)) {
                    continue;
                }
                hit.t = r.x;
                hit.triangle = i;
                hit.b = r.yz;
            }
        } else {
            vec4 l0 = rt_texel(u_rt_nodes, 4 * ref), l1 = rt_texel(u_rt_nodes, 4 * ref + 1);
            vec4 r0 = rt_texel(u_rt_nodes, 4 * ref + 2), r1 = rt_texel(u_rt_nodes, 4 * ref + 3);
            float tl = ray_aabb(o, inv_d, l0.xyz, l1.xyz, hit.t);
            float tr = ray_aabb(o, inv_d, r0.xyz, r1.xyz, hit.t);
            if (min(tl, tr) != RAY_MISS) {
                bool left = tl <= tr;
                if (max(tl, tr) != RAY_MISS && sp < RAYTRACE_STACK) {
                    stack[sp] = floatBitsToInt(left ? r0.w : l0.w);
                    stack_count[sp] = floatBitsToInt(left ? r1.w : l1.w);
                    stack_t[sp] = max(tl, tr);
                    ++sp;
                }
                ref = floatBitsToInt(left ? l0.w : r0.w);
                count = floatBitsToInt(left ? l1.w : r1.w);
                continue;
            }
        }
        // pop the next box still nearer than the nearest hit
        bool found = false;
        while (sp > 0) {
            --sp;
            if (stack_t[sp] < hit.t) {
                ref = stack[sp];
                count = stack_count[sp];
                found = true;
                break;
            }
        }
        if (!found) break;
    }
    return hit;
}

// RT_OPAQUE_AT: the opacity at which splats block a shadow ray (splat_proxies.OPAQUE_AT)
#define RT_OPAQUE_AT 0.5

// Whether the ray o + t d is blocked for 0 < t < t_max (shadow rays): by a solid triangle, or by
// the splats whose proxies it enters once the opacity it gathers through them reaches
// RT_OPAQUE_AT, i.e. the product of what each lets through (rt_splat_transmittance; in any
// order) falls to 1 - RT_OPAQUE_AT (viewer/raytrace/splat_proxies.py says why).
bool bvh_any_hit(vec3 o, vec3 d, float t_max) {
    if (u_rt_node_count == 0) return false;
    float seen = 1.0;
    vec3 inv_d = safe_inverse(d);
    int stack[RAYTRACE_STACK];
    int stack_count[RAYTRACE_STACK];
    int sp = 0;
    int ref = 0;
    int count = 0;
    for (;;) {
        if (count > 0) {
            for (int i = ref; i < ref + count; ++i) {
                vec4 e0, e1, e2;
                rt_edges(i, e0, e1, e2);
                vec3 r = ray_triangle_edges(o, d, e0.xyz, e1.xyz, e2.xyz);
                if (!(r.x > 0.0 && r.x < t_max)) continue;
                int s = rt_entered_splat(e0, e1, e2, d);
                if (s >= 0) {
                    seen *= rt_splat_transmittance(s, o, d, t_max);
                    if (seen <= 1.0 - RT_OPAQUE_AT) return true;
                } else if (s == -1 && rt_solid(rt_triangles[i], r.yz)) {
                    return true;
                }
            }
        } else {
            vec4 l0 = rt_texel(u_rt_nodes, 4 * ref), l1 = rt_texel(u_rt_nodes, 4 * ref + 1);
            vec4 r0 = rt_texel(u_rt_nodes, 4 * ref + 2), r1 = rt_texel(u_rt_nodes, 4 * ref + 3);
            float tl = ray_aabb(o, inv_d, l0.xyz, l1.xyz, t_max);
            float tr = ray_aabb(o, inv_d, r0.xyz, r1.xyz, t_max);
            if (tl != RAY_MISS || tr != RAY_MISS) {
                if (tl != RAY_MISS && tr != RAY_MISS && sp < RAYTRACE_STACK) {
                    stack[sp] = floatBitsToInt(r0.w);
                    stack_count[sp] = floatBitsToInt(r1.w);
                    ++sp;
                }
                bool left = tl != RAY_MISS;
                ref = floatBitsToInt(left ? l0.w : r0.w);
                count = floatBitsToInt(left ? l1.w : r1.w);
                continue;
            }
        }
        if (sp == 0) break;
        --sp;
        ref = stack[sp];
        count = stack_count[sp];
    }
    return false;
}

// Whether a ray whose closest hit missed (o + t d, 0 < t < t_max) reaches the environment: always
// without splats; with them, unless it passed between splats' opaque cores through enough of
// their Gaussians to be blocked (bvh_any_hit's rule; a closest hit stops at a core only, and on a
// surface tiled with splats the cores leave gaps: splat_proxies.py). What a ray so blocked would
// see is not a surface rays can shade; visibility ratios count it as occluded.
bool rt_escapes(vec3 o, vec3 d, float t_max) {
#if RT_SPLATS
    return !bvh_any_hit(o, d, t_max);
#else
    return true;
#endif
}

// The surface a ray hit: what the path tracer shades at a secondary vertex (the material's
// factors times its maps at TEXCOORD_0 - every map of the slot table the scene's lobes read; the
// interpolated vertex normal; no normal map, the coat's included). A lobe's maps are read only
// in a scene with the lobe (TRACED_*: its G-buffer channel), so a scene pays for what it uses;
// a material without a map takes its factors exactly (a branch, not a multiplication by 1).
#ifdef GBUFFER_HAS_DIELECTRIC
#if GBUFFER_HAS_DIELECTRIC
#define TRACED_SPECULAR_MAPS
#endif
#endif
#ifdef GBUFFER_HAS_CLEARCOAT
#if GBUFFER_HAS_CLEARCOAT
#define TRACED_CLEARCOAT_MAPS
#endif
#endif
#ifdef GBUFFER_HAS_IRIDESCENCE
#if GBUFFER_HAS_IRIDESCENCE
#define TRACED_IRIDESCENCE_FIELD
#endif
#endif
struct TracedSurface {
    vec3 p;           // world position
    vec3 ng;          // geometric normal (the triangle's winding: front face)
    vec3 n;           // shading normal (interpolated, unit)
    vec3 albedo;
    float roughness;  // perceptual
    float metallic;
    float specular;
    vec4 dielectric;  // KHR_materials_ior/specular F0 (rgb), F90 (a); a < 0: none (surface_f0_f90)
    vec2 clearcoat;   // KHR_materials_clearcoat factor, perceptual roughness (0: no coat)
#ifdef GBUFFER_HAS_SHEEN
#if GBUFFER_HAS_SHEEN
#define TRACED_SHEEN_FIELD
    vec4 sheen;       // KHR_materials_sheen colour (rgb; 0: none), roughness (a)
#endif
#endif
#ifdef GBUFFER_HAS_ANISOTROPY
#if GBUFFER_HAS_ANISOTROPY
#define TRACED_ANISOTROPY_FIELD
    vec4 anisotropy;  // KHR_materials_anisotropy direction (unit, in n's plane), strength (w)
#endif
#endif
#ifdef TRACED_IRIDESCENCE_FIELD
    vec3 iridescence; // KHR_materials_iridescence factor (0: none), thickness (nm), film IOR
#endif
    vec3 emission;    // radiance it emits
    bool double_sided;
    vec2 transmission; // KHR_materials_transmission factor, the volume's IOR (0: thin-walled)
    vec3 sigma;        // KHR_materials_volume's attenuation coefficient (per unit length)
#ifdef GBUFFER_HAS_DISPERSION
#if GBUFFER_HAS_DISPERSION
#define TRACED_DISPERSION_FIELD
    float dispersion;  // KHR_materials_dispersion 20 / V_d of a volume (0: none)
#endif
#endif
};
// the traced sheen (vec4(0.0) in a scene without one: TracedSurface then has no field for it)
#ifdef TRACED_SHEEN_FIELD
#define TRACED_SHEEN(t) ((t).sheen)
#else
#define TRACED_SHEEN(t) vec4(0.0)
#endif

#ifdef TRACED_ANISOTROPY_FIELD
// KHR_materials_anisotropy at a traced hit: the direction (cos, sin) (row.yz: the rotation's,
// turned by the map's direction where there is one, lib/anisotropy.glsl anisotropy_map_direction)
// in the triangle's UV frame (T along dp/du, B along -dp/dv, as the G-buffer's cotangent frame
// and the reference's), put into the plane of the shading normal n; (direction, strength row.x).
// A triangle without a UV frame takes an arbitrary tangent.
vec4 rt_anisotropy(uvec4 tri, vec3 p0, vec3 p1, vec3 p2, vec3 n, vec4 row) {
    vec2 t0 = vec2(rt_vertices[2u * tri.x].w, rt_vertices[2u * tri.x + 1u].w);
    vec2 d1 = vec2(rt_vertices[2u * tri.y].w, rt_vertices[2u * tri.y + 1u].w) - t0;
    vec2 d2 = vec2(rt_vertices[2u * tri.z].w, rt_vertices[2u * tri.z + 1u].w) - t0;
    vec3 e1 = p1 - p0;
    vec3 e2 = p2 - p0;
    float det = d1.x * d2.y - d1.y * d2.x;
    vec3 dpdu = (e1 * d2.y - e2 * d1.y) * det;  // dp/du, dp/dv times det^2 (the same sign)
    vec3 dpdv = (e2 * d1.x - e1 * d2.x) * det;
    vec3 t = dpdu - n * dot(n, dpdu);
    if (!(dot(t, t) > 1e-30)) {
        t = cross(n, abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0));
    }
    t = normalize(t);
    vec3 b = cross(n, t);
    if (dot(b, dpdv) > 0.0) b = -b;  // B along -dp/dv (mirrored UVs flip it)
    vec3 a = t * row.y + b * row.z;
    return vec4(normalize(a - n * dot(n, a)), row.x);
}
#endif

TracedSurface rt_surface(RayHit hit, vec3 o, vec3 d) {
    TracedSurface s;
    uvec4 tri = rt_triangles[hit.triangle];
    int m = int(tri.w);
    vec3 p0 = rt_position(tri.x), p1 = rt_position(tri.y), p2 = rt_position(tri.z);
    float w0 = 1.0 - hit.b.x - hit.b.y;
    s.p = o + d * hit.t;
    s.ng = normalize(cross(p1 - p0, p2 - p0));
    vec3 n = rt_vertices[2u * tri.x + 1u].xyz * w0 + rt_vertices[2u * tri.y + 1u].xyz * hit.b.x
             + rt_vertices[2u * tri.z + 1u].xyz * hit.b.y;
    float len = length(n);
    s.n = len > 1e-12 ? n / len : s.ng;
    vec2 uv = rt_uv(tri, hit.b);
    int base = m * RT_MATERIAL_ROWS;
    vec4 f0 = rt_materials[base + RT_ROW_BASE];
    vec4 f1 = rt_materials[base + RT_ROW_SURFACE];
    vec4 f2 = rt_materials[base + RT_ROW_EMISSION];
    s.albedo = f0.rgb * rt_map(m, RT_MAP_BASE_COLOR, uv, vec4(1.0)).rgb;
    vec4 mr = rt_map(m, RT_MAP_METALLIC_ROUGHNESS, uv, vec4(1.0));
    s.roughness = clamp(f1.x * mr.g, 0.0, 1.0);
    s.metallic = clamp(f1.y * mr.b, 0.0, 1.0);
    s.specular = f1.z;
    s.dielectric = rt_materials[base + RT_ROW_DIELECTRIC];
#ifdef TRACED_SPECULAR_MAPS
    // KHR_materials_specular's maps (A: factor, RGB: colour), as passes/mesh_surface.glsl
    if (s.dielectric.a >= 0.0
        && (rt_has_map(m, RT_MAP_SPECULAR) || rt_has_map(m, RT_MAP_SPECULAR_COLOR))) {
        vec4 spec = rt_materials[base + RT_ROW_SPECULAR];
        float factor = s.dielectric.a * rt_map(m, RT_MAP_SPECULAR, uv, vec4(1.0)).a;
        vec3 colour = spec.rgb * rt_map(m, RT_MAP_SPECULAR_COLOR, uv, vec4(1.0)).rgb;
        s.dielectric = vec4(dielectric_f0_ior(spec.a, colour, factor), factor);
    }
#endif
    s.clearcoat = rt_materials[base + RT_ROW_CLEARCOAT].xy;  // the coat on the vertex normal
#ifdef TRACED_CLEARCOAT_MAPS
    s.clearcoat *= vec2(rt_map(m, RT_MAP_CLEARCOAT, uv, vec4(1.0)).r,
                        rt_map(m, RT_MAP_CLEARCOAT_ROUGHNESS, uv, vec4(1.0)).g);
#endif
#ifdef TRACED_SHEEN_FIELD
    s.sheen = rt_materials[base + RT_ROW_SHEEN]
              * vec4(rt_map(m, RT_MAP_SHEEN_COLOR, uv, vec4(1.0)).rgb,
                     rt_map(m, RT_MAP_SHEEN_ROUGHNESS, uv, vec4(1.0)).a);
#endif
#ifdef TRACED_ANISOTROPY_FIELD
    vec4 aniso = rt_materials[base + RT_ROW_ANISOTROPY];
    if (rt_has_map(m, RT_MAP_ANISOTROPY)) {
        vec3 dir = anisotropy_map_direction(aniso.yz, rt_map(m, RT_MAP_ANISOTROPY, uv,
                                                             vec4(1.0)).rgb);
        aniso = vec4(aniso.x * dir.z, dir.xy, 0.0);
    }
    s.anisotropy = rt_anisotropy(tri, p0, p1, p2, s.n, aniso);
#endif
#ifdef TRACED_IRIDESCENCE_FIELD
    // the film (R: factor; G blends the minimum thickness to the maximum), as mesh_surface.glsl
    vec4 film = rt_materials[base + RT_ROW_IRIDESCENCE];
    s.iridescence = film.xyz;
    s.iridescence.x *= rt_map(m, RT_MAP_IRIDESCENCE, uv, vec4(1.0)).r;
    if (rt_has_map(m, RT_MAP_IRIDESCENCE_THICKNESS)) {
        s.iridescence.y = mix(film.w, film.y,
                              rt_map(m, RT_MAP_IRIDESCENCE_THICKNESS, uv, vec4(1.0)).g);
    }
#endif
    s.emission = f2.rgb * rt_map(m, RT_MAP_EMISSIVE, uv, vec4(1.0)).rgb;
    s.double_sided = f2.w > 0.5;
    s.transmission = rt_materials[base + RT_ROW_TRANSMISSION].xy;
#ifdef GBUFFER_HAS_TRANSMISSION
#if GBUFFER_HAS_TRANSMISSION
    // transmissionTexture (R) times the factor, as passes/mesh_surface.glsl
    if (rt_has_map(m, RT_MAP_TRANSMISSION)) {
        s.transmission.x *= rt_map(m, RT_MAP_TRANSMISSION, uv, vec4(1.0)).r;
    }
#endif
#endif
    s.sigma = rt_materials[base + RT_ROW_VOLUME].xyz;
#ifdef TRACED_DISPERSION_FIELD
    s.dispersion = rt_materials[base + RT_ROW_TRANSMISSION].z;  // Material.transmission_row
#endif
    return s;
}
