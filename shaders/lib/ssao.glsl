// ssao.glsl - screen-space visibility from the depth and normal buffers (thesis sec. 6.4,
// eqs. 6.19-6.20, after GS-IR): view-space reconstruction of a pixel, projection of a point back to
// the screen, and the depth test with thickness delta. View space looks down -Z; depth is the
// positive distance along the view axis. frag coordinates have (0, 0) at the bottom-left corner of
// the framebuffer, pixel centres at + 0.5. No uniforms, no main. Twins: learned/twins/ssao.py.
#include "lib/common.glsl"

// The view-space point seen at frag_coord with the given depth (thesis: x = z (u - c_x, v - c_y, 1)).
vec3 view_position(vec2 frag_coord, vec2 resolution, float depth, vec2 tan_half_fov) {
    vec2 ndc = frag_coord / resolution * 2.0 - 1.0;
    return depth * vec3(ndc * tan_half_fov, -1.0);
}

// Project a view-space point (in front of the camera) to (frag_coord.xy, depth).
vec3 view_to_frag(vec3 p_vs, vec2 resolution, vec2 tan_half_fov) {
    float depth = -p_vs.z;
    vec2 ndc = p_vs.xy / (max(depth, 1e-30) * tan_half_fov);
    return vec3((ndc * 0.5 + 0.5) * resolution, depth);
}

// The stored surface's depth along the ray through q_vs: the depth buffer holds the surface at the
// pixel centre, p_vs with normal n_vs; its tangent plane is intersected with the camera ray
// through q (first-order reconstruction between pixel centres, so a flat surface is exact).
// Where the ray grazes the plane the intersection is ill-conditioned: a q on the plane's front side
// (or on it, within 1e-4 of |q|) is taken as lying on or in front of that surface (its own depth:
// not occluded, as a floor seen edge-on at the horizon must be), one behind it falls back to the
// centre depth.
float surface_depth_at(vec3 q_vs, vec3 p_vs, vec3 n_vs, float depth_center) {
    float qn = dot(q_vs, n_vs);
    float len_q = length(q_vs);
    if (!(abs(qn) > 0.05 * len_q)) {
        return dot(q_vs - p_vs, n_vs) >= -1e-4 * len_q ? -q_vs.z : depth_center;
    }
    return -q_vs.z * (dot(p_vs, n_vs) / qn);
}

// Thesis eq. 6.20: a sample at depth z is occluded when it lies behind the stored surface depth z_d
// by less than the thickness delta. A relative bias of 1e-4 keeps points on the surface visible;
// z_d <= 0 (background) never occludes.
float ssao_occluded(float z, float z_d, float thickness) {
    return (z_d > 0.0 && z > z_d * (1.0 + 1e-4) && z < z_d + thickness) ? 1.0 : 0.0;
}

// Joint bilateral weight of a low-resolution sample (view-space point q_vs, unit normal nq_vs)
// for a full-resolution pixel (p_vs, n_vs) when an SSAO pass ran at reduced scale
// (passes/ssao_upsample.glsl): the bilinear weight, times how close p lies to the sample's tangent
// plane (relative to p's depth: 0 beyond 2 %, so a sample on another surface at a depth edge
// drops out while a plane seen at a grazing angle, whose depth changes fast from pixel to pixel,
// keeps its weight), times cos^8 of the angle between the normals (a crease or a sphere's
// silhouette against the floor it rests on). 0 for the weight means "not this sample".
float ssao_upsample_weight(float bilinear, vec3 p_vs, vec3 n_vs, vec3 q_vs, vec3 nq_vs) {
    float plane = abs(dot(p_vs - q_vs, nq_vs)) / max(-p_vs.z, 1e-30);
    float w_plane = max(1.0 - plane * 50.0, 0.0);
    float c = max(dot(n_vs, nq_vs), 0.0);
    float c2 = c * c;
    float c4 = c2 * c2;
    return bilinear * w_plane * (c4 * c4);
}
