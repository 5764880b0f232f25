// bvh.glsl - the pure functions of ray casting: a ray against one triangle and against one box.
// The traversal that uses them over the scene's BVH (its buffers are pass state) is
// passes/raytrace.glsl. No uniforms, no main. Twins: learned/twins/bvh.py.
#include "lib/common.glsl"

#define RAY_MISS 3.0e38  // ray_aabb's answer for a box the ray does not enter

// 1 / d per component, with a zero component replaced by a tiny number of its sign: the slab
// test then sees +-3e30 instead of an infinity whose product with a zero distance is NaN.
vec3 safe_inverse(vec3 d) {
    vec3 s = mix(vec3(-1.0e-30), vec3(1.0e-30), greaterThanEqual(d, vec3(0.0)));
    return 1.0 / mix(d, s, lessThan(abs(d), vec3(1.0e-30)));
}

// Kay & Kajiya 1986, "Ray Tracing Complex Scenes" (the slab test): the distance at which the
// ray o + t d (inv_d = safe_inverse(d)) enters the box [lo, hi] within [0, t_max], or RAY_MISS.
// A ray starting inside the box enters at 0.
float ray_aabb(vec3 o, vec3 inv_d, vec3 lo, vec3 hi, float t_max) {
    vec3 t0 = (lo - o) * inv_d;
    vec3 t1 = (hi - o) * inv_d;
    vec3 near = min(t0, t1);
    vec3 far = max(t0, t1);
    float t_near = max(max(near.x, near.y), max(near.z, 0.0));
    float t_far = min(min(far.x, far.y), min(far.z, t_max));
    return t_near <= t_far ? t_near : RAY_MISS;
}

// Moller & Trumbore 1997, "Fast, Minimum Storage Ray/Triangle Intersection": the hit of the ray
// o + t d with the triangle (p0, p0 + e1, p0 + e2) as (t, b1, b2), b1 and b2 the barycentric
// weights of its 2nd and 3rd vertices; t = -1 where the ray is parallel to the triangle's plane or
// passes outside it. Both faces are hit (culling is the caller's). A hit behind the origin has
// t < 0. The edges as given (the traversal reads them precomputed: passes/raytrace.glsl).
vec3 ray_triangle_edges(vec3 o, vec3 d, vec3 p0, vec3 e1, vec3 e2) {
    vec3 pv = cross(d, e2);
    float det = dot(e1, pv);
    if (det == 0.0) return vec3(-1.0, 0.0, 0.0);
    float inv_det = 1.0 / det;
    vec3 tv = o - p0;
    float b1 = dot(tv, pv) * inv_det;
    if (b1 < 0.0 || b1 > 1.0) return vec3(-1.0, 0.0, 0.0);
    vec3 qv = cross(tv, e1);
    float b2 = dot(d, qv) * inv_det;
    if (b2 < 0.0 || b1 + b2 > 1.0) return vec3(-1.0, 0.0, 0.0);
    return vec3(dot(e2, qv) * inv_det, b1, b2);
}

// ray_triangle_edges of the triangle (p0, p1, p2): e1 = p1 - p0, e2 = p2 - p0.
vec3 ray_triangle(vec3 o, vec3 d, vec3 p0, vec3 p1, vec3 p2) {
    return ray_triangle_edges(o, d, p0, p1 - p0, p2 - p0);
}

// Where a ray leaving surface point p (geometric normal ng) along d starts: p moved off the
// surface towards d's side by a distance that scales with p's magnitude (float32 positions
// carry a relative error of ~1e-7; 1e-4 relative clears it with a margin), so the ray does not
// hit the surface it leaves.
vec3 ray_offset(vec3 p, vec3 ng, vec3 d) {
    float scale = 1.0e-4 * max(1.0, max(abs(p.x), max(abs(p.y), abs(p.z))));
    return p + ng * (dot(ng, d) >= 0.0 ? scale : -scale);
}

// A ray o + t d in a Gaussian's unit frame (the Gaussian exp(-|x|^2 / 2) there; o, d mapped by
// the splat's affine map, d not unit): (t, q^2) at the Gaussian's peak along the ray within
// [0, t_max], q^2 the squared Mahalanobis distance there. The line's peak is at
// t* = -(o.d) / (d.d) (3D Gaussian Ray Tracing, Moenne-Loccoz et al. 2024, evaluates a particle
// there); clamped to the segment, a ray that starts past the peak or stops short of it is
// judged where it comes nearest.
vec2 gaussian_ray_peak(vec3 o, vec3 d, float t_max) {
    float dd = dot(d, d);
    float t = dd > 0.0 ? clamp(-dot(o, d) / dd, 0.0, t_max) : 0.0;
    vec3 x = o + t * d;
    return vec2(t, dot(x, x));
}

// Where the ray o + t d enters the sphere |x|^2 = r2 (o, d in an ellipsoid's unit frame, d not
// unit: the ellipsoid itself), or -1 where it misses it, starts inside it, enters behind o or
// r2 <= 0 (no ellipsoid: a ray through its centre would touch the point).
// The nearer root of (d.d) t^2 + 2 (o.d) t + o.o - r2, in the form that keeps its digits.
float ellipsoid_entry(vec3 o, vec3 d, float r2) {
    float a = dot(d, d);
    float b = dot(o, d);
    float c = dot(o, o) - r2;
    float disc = b * b - a * c;
    if (!(a > 0.0) || !(r2 > 0.0) || c <= 0.0 || b >= 0.0 || disc < 0.0) return -1.0;
    return c / (-b + sqrt(disc));  // = (-b - sqrt(disc)) / a, without the cancellation
}
