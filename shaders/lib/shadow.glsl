// shadow.glsl - shadow-map lookups: receiver bias, percentage-closer soft shadows (PCSS: blocker
// search, then a PCF kernel whose radius follows the light's size). The map stores, per texel, the
// normalised depth (0 nearest the light, 1 farthest) of the nearest occluder, in a depth texture
// (24-bit) read through a NEAREST sampler clamped to its edge (no comparison mode); 1 where
// nothing is. Three kinds of map
// (viewer/lighting/shadow_frames.py): orthographic (directional lights, the sun), perspective (spot lights:
// depth linear along the axis) and cube (point lights: six faces in an atlas 3 x 2 faces, depth
// the distance from the light). No uniforms, no main. Twins: learned/twins/shadow.py.
#include "lib/common.glsl"

#define SHADOW_SEARCH_SAMPLES 16
#define SHADOW_PCF_SAMPLES 32
#define SHADOW_MIN_SAMPLES 4      // taps of a filter disk no wider than a few texels
#define SHADOW_MAX_SEARCH_UV 0.25  // the blocker search never covers more than this radius
// perspective and cube maps: the blocker search looks for occluders no nearer the light than this
// fraction of the receiver's distance (a search reaching up to the light would cover most of the
// map with a few samples, and miss the occluder it is looking for: noise in the umbra)
#define SHADOW_NEAREST_BLOCKER 0.25
#define SHADOW_ORTHO 1
#define SHADOW_PERSPECTIVE 2
#define SHADOW_CUBE 3
// what a program compiles (viewer/lighting/lights.py light_defines): SHADOW_POSITIONAL 0 when every map it
// reads is orthographic, SHADOW_CUBE_MAPS 0 when none is a cube map (their branches compile out)
#ifndef SHADOW_POSITIONAL
#define SHADOW_POSITIONAL 1
#endif
#ifndef SHADOW_CUBE_MAPS
#define SHADOW_CUBE_MAPS 1
#endif
// SHADOW_CASCADE_MAPS 1 when a map read is a cascade atlas (viewer/lighting/cascades.py): a face below -1
// is then cascade -2 - face's tile (2 tiles wide); 0 compiles that branch out
#ifndef SHADOW_CASCADE_MAPS
#define SHADOW_CASCADE_MAPS 0
#endif
#define SHADOW_MAX_CASCADES 4
#define SHADOW_CASCADE_MARGIN 0.02  // viewer/lighting/cascades.py SELECT_MARGIN
#define SHADOW_IS_ORTHO(lens) (SHADOW_POSITIONAL == 0 || (lens).x < 1.5)
#define SHADOW_IS_2D(face) (SHADOW_CUBE_MAPS == 0 || (face) < 0)

// Sample i of n on a unit disk (Vogel's golden-angle spiral), rotated by phi: evenly spread for
// any n, and a per-pixel phi turns banding into noise. The angle is reduced to [0, 2 pi) in
// turns first (the golden angle is 0.381966011 of a turn): GPU sine and cosine are accurate only
// near [-pi, pi] (on an H200, i x 2.4 rad up to 160 rad put the point 1.3e-4 off).
vec2 vogel_disk(int i, int n, float phi) {
    float r = sqrt((float(i) + 0.5) / float(n));
    float theta = 6.28318531 * fract(float(i) * 0.381966011 + phi * 0.159154943);
    return r * vec2(cos(theta), sin(theta));
}

// The next sample's direction on Vogel's spiral: dir turned by the golden angle (the filters
// walk the spiral by this rotation instead of a cos and sin per sample).
vec2 vogel_turn(vec2 dir) {
    const vec2 g = vec2(-0.73736888, 0.67549030);  // (cos, sin) of 2.39996323
    return vec2(dir.x * g.x - dir.y * g.y, dir.x * g.y + dir.y * g.x);
}

// A pixel's rotation of the shadow filters' sample disk: interleaved gradient noise (Jimenez
// 2014) of its fragment coordinates, in [0, 2 pi): the filter's pattern becomes noise, not bands.
float shadow_phi(vec2 frag_coord) {
    return 6.28318531 * fract(52.9829189 * fract(dot(frag_coord, vec2(0.06711056, 0.00583715))));
}

// Taps of a filter disk of radius r_uv on a map of `size` texels a side: about one per two texels
// it covers (pi r^2 / 2: the per-pixel rotation spreads them), at least SHADOW_MIN_SAMPLES, at
// most n_max: a hard shadow's one-texel kernel needs 4, not 32.
int shadow_taps(float r_uv, float size, int n_max) {
    float r = r_uv * size;
    // min(max()), not clamp(): clamp is undefined when n_max < SHADOW_MIN_SAMPLES (an H200 gave
    // the minimum where this and the twin give n_max); in floats, before the int conversion
    return int(min(max(ceil(1.57079633 * r * r), float(SHADOW_MIN_SAMPLES)), float(n_max)));
}

// The receiver's world position moved off its surface before the lookup (normal-offset bias):
// along the normal by 1.5 texels, more as the light grazes the surface (up to 3 more at
// NoL -> 0), so a lit plane never shadows itself at any incidence.
vec3 shadow_receiver(vec3 p_ws, vec3 n_ws, vec3 l_ws, float texel_world) {
    float NoL = clamp(dot(n_ws, l_ws), 0.0, 1.0);
    return p_ws + n_ws * texel_world * (1.5 + 3.0 * (1.0 - NoL));
}

// The depth stored at uv (nearest texel, clamped to the map's edge): the map's sampler is
// NEAREST and clamps to its edge (viewer/graph/resources.py ShadowMapDesc), so a sampled read
// is the texel floor(uv size), clamped. (On llvmpipe a sampled read costs about half a
// texelFetch with its index arithmetic, and the filters' taps are most of a lookup's cost.)
float shadow_depth_at(sampler2D map, vec2 uv) {
    return textureLod(map, uv, 0.0).r;
}

// The texel t (texel units: floor(t) is its index) of an atlas of `size` texels, sampled at
// its centre (shadow_depth_at's NEAREST read: no index arithmetic, exact at any precision).
float shadow_atlas_depth(sampler2D map, vec2 t, vec2 size) {
    return textureLod(map, (floor(t) + 0.5) / size, 0.0).r;
}

// Texels a side of the map region that `face` addresses: a 2D map's (face -1), a cube face's
// (face >= 0: the atlas is 2 faces high), a cascade tile's (face < -1: the atlas is 2 tiles wide).
float shadow_map_size(sampler2D map, int face) {
    ivec2 size = textureSize(map, 0);
    if (SHADOW_CASCADE_MAPS != 0 && face < -1) return float(size.x / 2);
    return float(size.y) / (SHADOW_IS_2D(face) ? 1.0 : 2.0);
}

// The depth stored at uv of cascade k's tile (nearest texel, clamped to the tile's edge).
float shadow_tile_depth(sampler2D map, vec2 uv, int k) {
    vec2 size = vec2(textureSize(map, 0));
    float n = 0.5 * size.x;
    vec2 t = clamp(uv * n, vec2(0.0), vec2(n - 1.0));
    return shadow_atlas_depth(map, t + vec2(k % 2, k / 2) * n, size);
}

// The cube face (0..5: +X, -X, +Y, -Y, +Z, -Z) holding direction d (from the light), and d's
// (u, v) on it; the faces' axes are viewer/lighting/shadow_frames.py CUBE_FACES.
vec3 shadow_cube_face(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) {
        return d.x > 0.0 ? vec3(0.5 - 0.5 * d.z / a.x, 0.5 + 0.5 * d.y / a.x, 0.0)
                         : vec3(0.5 + 0.5 * d.z / a.x, 0.5 + 0.5 * d.y / a.x, 1.0);
    }
    if (a.y >= a.z) {
        return d.y > 0.0 ? vec3(0.5 + 0.5 * d.x / a.y, 0.5 - 0.5 * d.z / a.y, 2.0)
                         : vec3(0.5 + 0.5 * d.x / a.y, 0.5 + 0.5 * d.z / a.y, 3.0);
    }
    return d.z > 0.0 ? vec3(0.5 + 0.5 * d.x / a.z, 0.5 + 0.5 * d.y / a.z, 4.0)
                     : vec3(0.5 - 0.5 * d.x / a.z, 0.5 + 0.5 * d.y / a.z, 5.0);
}

// The direction (from the light, not unit) of the point (u, v) of face `face`'s plane, extended
// beyond [0, 1]: axis + (2u - 1) right + (2v - 1) up.
vec3 shadow_cube_dir(int face, vec2 uv) {
    vec2 st = uv * 2.0 - 1.0;
    if (face == 0) return vec3(1.0, st.y, -st.x);
    if (face == 1) return vec3(-1.0, st.y, st.x);
    if (face == 2) return vec3(st.x, 1.0, -st.y);
    if (face == 3) return vec3(st.x, -1.0, st.y);
    if (face == 4) return vec3(st.x, st.y, 1.0);
    return vec3(-st.x, st.y, -1.0);
}

// The depth a map stores at uv: a 2D map's (face < 0: shadow_depth_at), or, for a cube atlas,
// the texel of the direction through (u, v) of face `face`'s plane, on whichever face holds it
// (a filter disk crossing a face's edge reads the neighbour face).
float shadow_sample(sampler2D map, vec2 uv, int face) {
    if (SHADOW_CASCADE_MAPS != 0 && face < -1) return shadow_tile_depth(map, uv, -2 - face);
    if (SHADOW_IS_2D(face)) return shadow_depth_at(map, uv);
    vec3 fc = shadow_cube_face(shadow_cube_dir(face, uv));
    int f = int(fc.z);
    vec2 size = vec2(textureSize(map, 0));
    float n = 0.5 * size.y;
    vec2 t = clamp(fc.xy * n, vec2(0.0), vec2(n - 1.0));
    return shadow_atlas_depth(map, t + vec2(f % 3, f / 3) * n, size);
}

// The receiver's depth gradient in the map (receiver-plane depth bias): a planar receiver of
// light-space normal m (the normal through the inverse transpose of the world -> map matrix)
// has depth z + dot(shadow_depth_slope(m), offset) at a uv offset, so samples of a filter
// footprint compare against the receiver's own plane, not its centre's depth (a slanted receiver
// would otherwise shadow itself under a wide kernel). Clamped to 4 depth units per uv unit where
// the light grazes the surface.
vec2 shadow_depth_slope(vec3 m) {
    vec2 g = -m.xy / (abs(m.z) > 1e-6 ? m.z : 1e-6);
    float len_g = length(g);
    return len_g > 4.0 ? g * (4.0 / len_g) : g;
}

// The map-space normal of a receiver plane of world normal n in a map whose (u, v, depth) have
// the world gradients du, dv, dd at the receiver (any kind of map: its local affine
// approximation; dd may be any function's gradient, e.g. 1 / distance's): the inverse transpose
// of that Jacobian times n, up to a scale no slope sees: the rows of the cofactor matrix, cross
// products of the gradients. The plane's slope of that function per uv is -m.xy / m.z.
vec3 shadow_plane_normal(vec3 du, vec3 dv, vec3 dd, vec3 n) {
    return vec3(dot(cross(dv, dd), n), dot(cross(dd, du), n), dot(cross(du, dv), n));
}

// Radius (uv) of the map region whose occluders at depth zb can hide part of the light from a
// receiver at depth zr (zb = 0: the blocker search's radius). lens = (kind, scale, near, range):
// orthographic (a disk light of angular radius a, map `extent` wide): scale = tan(a) / extent,
// radius = scale (zr - zb) range; perspective and cube (a sphere light of radius R, distances
// z = near + depth range from it): similar triangles give R (1 / zb - 1 / zr) per unit of
// distance, scale = R / (2 tan(half-angle)) (a cube face: half-angle 45 degrees).
float shadow_penumbra_uv(vec4 lens, float zr, float zb) {
    if (SHADOW_IS_ORTHO(lens)) return lens.y * (zr - zb) * lens.w;
    float r = lens.z + zr * lens.w;
    float b = lens.z + zb * lens.w;
    return lens.y * (1.0 / b - 1.0 / r);
}

// The receiver's depth in the map at the offset o from uv (its filter footprint's samples
// compare against the receiver's own plane, not its centre's depth: a slanted receiver would
// otherwise shadow itself under a wide kernel). plane = (z, dz): orthographic maps, the depth z at
// uv and its slope dz (shadow_depth_slope); perspective and cube maps, the inverse of the distance
// along the axis (of the cube face `face`) and its slope: 1 / distance is affine in (u, v) over a
// plane, so the plane's depth is exact at any offset (kept at most 4 x the centre's where the
// plane turns away from the light).
float shadow_receiver_depth(vec3 plane, vec4 lens, int face, vec2 uv, vec2 o) {
    float z = plane.x + dot(plane.yz, o);
    if (SHADOW_IS_ORTHO(lens)) return z;
    float axial = 1.0 / max(z, 0.25 * plane.x);
    float dist = SHADOW_IS_2D(face) ? axial : axial * length(shadow_cube_dir(face, uv + o));
    return (dist - lens.z) / lens.w;
}

// PCSS step 1: mean depth of the occluders in front of the receiver (plane: see
// shadow_receiver_depth; a texel of depth 1 holds nothing and never occludes, however far the
// receiver's plane extends) within radius search_uv of uv; -1 where none is (fully lit); face: the
// cube face uv is on (-1: a 2D map). Sets umbra when every sample occludes. The receiver's own
// texel is the first sample, then the disk's: an occluder that hides the light's centre is found
// however far the search spreads its other samples (a small occluder under a wide light over a
// large scene, whose search radius covers the whole scene's depth range, stays in its umbra).
// dir: the unit direction of the spiral's first sample (the pixel's rotation, shadow_phi, as
// (cos, sin)); size: texels a side of the map region face addresses (shadow_map_size). Both are
// found once a lookup, for both filters. The spiral's even taps are read first (a sparser spiral
// over the whole disk), its odd taps only where they or the centre found an occluder: a receiver
// with nothing in reach (most of a lit frame) reads half the taps, and wherever an occluder is
// found the mean and the umbra are the whole spiral's. One loop, which a block of lit pixels
// leaves halfway (a second loop for the odd taps saved more on llvmpipe, but made a program
// with three lights' perspective or cube lookups take minutes to compile).
float shadow_blocker_depth(sampler2D map, vec2 uv, vec3 plane, float search_uv, vec2 dir,
                           float size, vec4 lens, int face, bool adaptive, out bool umbra) {
    int n = !adaptive ? SHADOW_SEARCH_SAMPLES : shadow_taps(search_uv, size,
                                                           SHADOW_SEARCH_SAMPLES);
    float inv_n = 1.0 / float(n);
    float centre = shadow_sample(map, uv, face);
    bool hit = centre < min(shadow_receiver_depth(plane, lens, face, uv, vec2(0.0)), 1.0);
    float sum = hit ? centre : 0.0;
    float count = hit ? 1.0 : 0.0;
    int even = (n + 1) / 2;  // taps 0, 2, 4, ... first
    vec2 d = dir;
    for (int k = 0; k < n; ++k) {
        if (k == even) {
            if (count == 0.0) break;  // neither they nor the centre occlude: lit
            d = vogel_turn(dir);      // then taps 1, 3, 5, ...
        }
        int i = k < even ? 2 * k : 2 * (k - even) + 1;
        vec2 o = sqrt((float(i) + 0.5) * inv_n) * search_uv * d;
        float z = shadow_sample(map, uv + o, face);
        if (z < min(shadow_receiver_depth(plane, lens, face, uv, o), 1.0)) {
            sum += z;
            count += 1.0;
        }
        d = vogel_turn(vogel_turn(d));
    }
    umbra = count == float(n + 1);
    return count > 0.0 ? sum / count : -1.0;
}

// Percentage-closer filter: the fraction of disk samples of radius r_uv around uv (shadow_taps
// of them where adaptive, else SHADOW_PCF_SAMPLES) whose stored depth does not occlude the
// receiver's plane (shadow_receiver_depth; depth 1, nothing, never occludes); dir and size as
// shadow_blocker_depth's.
float shadow_pcf(sampler2D map, vec2 uv, vec3 plane, float r_uv, vec2 dir, float size,
                 vec4 lens, int face, bool adaptive) {
    int n = !adaptive ? SHADOW_PCF_SAMPLES : shadow_taps(r_uv, size, SHADOW_PCF_SAMPLES);
    float inv_n = 1.0 / float(n);
    float lit = 0.0;
    for (int i = 0; i < n; ++i) {
        vec2 o = sqrt((float(i) + 0.5) * inv_n) * r_uv * dir;
        lit += shadow_sample(map, uv + o, face) >= min(shadow_receiver_depth(plane, lens, face,
                                                                             uv, o), 1.0)
            ? 1.0 : 0.0;
        dir = vogel_turn(dir);
    }
    return lit * inv_n;
}

// PCSS visibility at the map point s = (u, v, depth) of a receiver (after shadow_receiver) whose
// plane is `plane` (shadow_receiver_depth), for a light of lens (shadow_penumbra_uv); face: the
// cube face s is on (-1: a 2D map; below -1: a cascade tile). The blocker search covers every
// occluder that can reach the receiver (at most SHADOW_MAX_SEARCH_UV; for perspective and cube maps the occluders at least
// SHADOW_NEAREST_BLOCKER of its distance from the light); where none is, lit; where every search sample
// occludes, in the umbra (the PCF disk is never wider than the search's); else PCF over the
// penumbra's region, at least one texel wide (a hard shadow is still filtered over a texel so
// it does not alias). Outside the map: lit.
float shadow_pcss(sampler2D map, vec3 s, vec3 plane, vec4 lens, float phi, int face,
                  bool adaptive) {
    if (any(lessThan(s, vec3(0.0))) || any(greaterThan(s, vec3(1.0)))) return 1.0;
    float size = shadow_map_size(map, face);
    float texel_uv = 1.0 / size;
    vec2 dir = vec2(cos(phi), sin(phi));  // the spiral's first direction, both filters
    float nearest = SHADOW_IS_ORTHO(lens) ? 0.0 : max(0.0, ((lens.z + s.z * lens.w)
                                                   * SHADOW_NEAREST_BLOCKER - lens.z) / lens.w);
    float search = clamp(shadow_penumbra_uv(lens, s.z, nearest), 1.5 * texel_uv,
                         SHADOW_MAX_SEARCH_UV);
    bool umbra;
    float blocker = shadow_blocker_depth(map, s.xy, plane, search, dir, size, lens, face,
                                         adaptive, umbra);
    if (blocker < 0.0) return 1.0;
    if (adaptive && umbra) return 0.0;
    float r = max(shadow_penumbra_uv(lens, s.z, blocker), texel_uv);
    return shadow_pcf(map, s.xy, plane, r, dir, size, lens, face, adaptive);
}

// Visibility of a directional light of angular radius `angle` (radians) at the light-space point
// s of a receiver in an orthographic map `extent` world units wide and depth_range deep
// (shadow_pcss with that light's lens and every tap: the sun's lookup, whose penumbrae the
// golden images hold).
float shadow_visibility(sampler2D map, vec3 s, vec2 dz, float angle, float depth_range,
                        float extent, float phi) {
    vec4 lens = vec4(1.0, tan(clamp(angle, 0.0, 0.3)) / extent, 0.0, depth_range);
    return shadow_pcss(map, s, vec3(s.z, dz), lens, phi, -1, false);
}

// The fraction of a light that reaches the surface point p (normal n, world space) through its
// shadow map: m the map's world -> (u w, v w, depth, w) (a cube map's faces are made here), lens
// (shadow_penumbra_uv; lens.x = 0: no map, lit), offset the normal offset (world units for an
// orthographic map, per unit of distance from the light for the others), light_pos the light's
// position (perspective, cube), l the unit direction towards the light at p.
float shadow_light_visibility(sampler2D map, mat4 m, vec4 lens, float offset, vec3 light_pos,
                              vec3 l, vec3 p, vec3 n, float phi) {
    if (lens.x < 0.5) return 1.0;
    bool ortho = SHADOW_IS_ORTHO(lens);
    vec3 q = shadow_receiver(p, n, l, ortho ? offset : offset * distance(p, light_pos));
    int face = -1;
    if (SHADOW_CUBE_MAPS != 0 && lens.x > 2.5) {  // the face of the receiver's direction, as a perspective frame
        vec3 d = q - light_pos;
        face = int(shadow_cube_face(d).z);
        vec3 a = shadow_cube_dir(face, vec2(0.5));
        vec3 r = shadow_cube_dir(face, vec2(1.0, 0.5)) - a;
        vec3 t = shadow_cube_dir(face, vec2(0.5, 1.0)) - a;
        m = transpose(mat4(vec4(0.5 * (r + a), -0.5 * dot(r + a, light_pos)),
                           vec4(0.5 * (t + a), -0.5 * dot(t + a, light_pos)),
                           vec4(0.0), vec4(a, -dot(a, light_pos))));
    }
    vec4 h = m * vec4(q, 1.0);
    vec3 s = vec3(h.xy / h.w, h.z);
    vec3 m3 = vec3(m[0][3], m[1][3], m[2][3]);
    vec3 du = (vec3(m[0][0], m[1][0], m[2][0]) - s.x * m3) / h.w;
    vec3 dv = (vec3(m[0][1], m[1][1], m[2][1]) - s.y * m3) / h.w;
    if (ortho) {
        vec2 dz = shadow_depth_slope(shadow_plane_normal(du, dv, vec3(m[0][2], m[1][2], m[2][2]),
                                                         n));
        return shadow_pcss(map, s, vec3(s.z, dz), lens, phi, face, true);
    }
    // perspective and cube: the plane as 1 / (distance along the axis), affine in (u, v)
    if (!SHADOW_IS_2D(face)) s.z = (distance(q, light_pos) - lens.z) / lens.w;  // the distance
    vec3 c = shadow_plane_normal(du, dv, -m3 / (h.w * h.w), n);
    vec2 g = -c.xy / (abs(c.z) > 1e-30 ? c.z : 1e-30);
    return shadow_pcss(map, s, vec3(1.0 / h.w, g), lens, phi, face, true);
}

// Cascade c's (u, v, depth) of the point s = (u, v, depth) of the whole-scene frame it shares
// (viewer/lighting/cascades.py ShadowCascades): c = (scale, u0, v0, unused), uv_c = (uv - (u0, v0)) scale.
vec3 shadow_cascade_uv(vec3 s, vec4 c) {
    return vec3((s.xy - c.yz) * c.x, s.z);
}

// The first of `count` cascades whose tile holds the whole-scene frame's point uv at least
// SHADOW_CASCADE_MARGIN inside its edges (cascades nearest the camera first); the last where none
// does (its own lookup then finds the point outside: lit).
int shadow_cascade_index(vec2 uv, vec4 c0, vec4 c1, vec4 c2, vec4 c3, int count) {
    for (int k = 0; k < SHADOW_MAX_CASCADES; ++k) {
        if (k >= count - 1) return k;
        vec4 c = k == 0 ? c0 : (k == 1 ? c1 : c2);
        vec2 t = (uv - c.yz) * c.x;
        if (all(greaterThanEqual(t, vec2(SHADOW_CASCADE_MARGIN))) &&
            all(lessThanEqual(t, vec2(1.0 - SHADOW_CASCADE_MARGIN)))) return k;
    }
    return count - 1;
}

// The fraction of a directional light reaching p (normal n; l the unit direction towards the
// light) through its cascades: m the whole-scene (square) frame, lens its lens (shadow_penumbra_uv)
// and offset its normal offset; c0..c3 the cascades' boxes (shadow_cascade_uv), count of them.
// The cascade is chosen at the unbiased point, then the receiver is offset by that cascade's
// texel (offset / scale) and looked up in its tile with the lens scaled to it: the penumbra is
// the same in world units, its uv radius scale times larger. adaptive: shadow_pcss's.
float shadow_cascade_visibility(sampler2D map, mat4 m, vec4 lens, float offset, vec4 c0, vec4 c1,
                                vec4 c2, vec4 c3, int count, vec3 l, vec3 p, vec3 n, float phi,
                                bool adaptive) {
    int k = shadow_cascade_index((m * vec4(p, 1.0)).xy, c0, c1, c2, c3, count);
    vec4 c = k == 0 ? c0 : (k == 1 ? c1 : (k == 2 ? c2 : c3));
    vec3 q = shadow_receiver(p, n, l, offset / c.x);
    vec3 s = shadow_cascade_uv((m * vec4(q, 1.0)).xyz, c);
    vec3 du = vec3(m[0][0], m[1][0], m[2][0]) * c.x;
    vec3 dv = vec3(m[0][1], m[1][1], m[2][1]) * c.x;
    vec2 dz = shadow_depth_slope(shadow_plane_normal(du, dv, vec3(m[0][2], m[1][2], m[2][2]), n));
    vec4 lens_c = vec4(lens.x, lens.y * c.x, lens.z, lens.w);
    return shadow_pcss(map, s, vec3(s.z, dz), lens_c, phi, -2 - k, adaptive);
}

// The fraction of a directional light (unit l towards it) reaching p (normal n) through one tile
// of an atlas 2 tiles wide (the environment's shadow directions: viewer/lighting/shadow_frames.py
// EnvShadowFrames): tile `tile`, whose frame m maps world -> (u, v, depth) within the tile, lens
// its lens (shadow_penumbra_uv) and offset its normal offset (world units). PCSS as
// shadow_light_visibility's orthographic case, every tap adaptive.
float shadow_tile_visibility(sampler2D map, mat4 m, vec4 lens, float offset, int tile, vec3 l,
                             vec3 p, vec3 n, float phi) {
    vec3 s = (m * vec4(shadow_receiver(p, n, l, offset), 1.0)).xyz;
    vec3 du = vec3(m[0][0], m[1][0], m[2][0]);
    vec3 dv = vec3(m[0][1], m[1][1], m[2][1]);
    vec2 dz = shadow_depth_slope(shadow_plane_normal(du, dv, vec3(m[0][2], m[1][2], m[2][2]), n));
    return shadow_pcss(map, s, vec3(s.z, dz), lens, phi, -2 - tile, true);
}
