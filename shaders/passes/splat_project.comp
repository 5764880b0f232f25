// splat_project.comp - per-splat preprocessing (one invocation per splat): EWA projection to a
// screen-space conic and quad axes, the baked SH colour along the view ray, the camera-facing
// normal, and the depth key for sorting. Reads world-space splats, writes one 24-float record each.
// Records of culled splats (centre behind the near plane or beyond the far plane) get opacity 0.
#include "lib/splat.glsl"

layout(local_size_x = 128) in;

// inputs for splats [u_first, u_first + u_count), bound as ranges starting at u_first
layout(std430, binding = 0) readonly buffer Geometry { float geo[]; };   // 12 per splat
layout(std430, binding = 1) readonly buffer Material { float mat[]; };   // 8 per splat
layout(std430, binding = 2) readonly buffer SH { float sh[]; };          // u_sh_count * 3 per splat
// outputs for all splats
layout(std430, binding = 3) writeonly buffer Projected { float proj[]; }; // SPLAT_RECORD per splat
layout(std430, binding = 4) writeonly buffer Keys { float keys[]; };      // view depth
layout(std430, binding = 5) writeonly buffer Order { uint order[]; };     // identity

uniform mat4 u_view;         // world -> view
uniform mat4 u_projection;   // view -> clip
uniform vec3 u_camera_ws;    // eye position
uniform vec4 u_focal_tan;    // (fx, fy, tan(fov_x / 2), tan(fov_y / 2)), f in pixels
uniform vec2 u_resolution;   // (W, H)
uniform vec2 u_near_far;
uniform uint u_first;
uniform uint u_count;
uniform int u_sh_count;      // K = 1, 4, 9 or 16

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) {
        return;
    }
    uint id = u_first + i;
    uint g = i * 12u;
    vec3 mean = vec3(geo[g], geo[g + 1u], geo[g + 2u]);
    float opacity = geo[g + 3u];
    vec4 q = vec4(geo[g + 4u], geo[g + 5u], geo[g + 6u], geo[g + 7u]);
    vec3 sigma = vec3(geo[g + 8u], geo[g + 9u], geo[g + 10u]);

    vec3 t_vs = (u_view * vec4(mean, 1.0)).xyz;
    // the cull decision and the sort key from the bit-reproducible depth (see splat_view_depth)
    float depth = splat_view_depth(vec4(u_view[0][2], u_view[1][2], u_view[2][2], u_view[3][2]),
                                   mean);
    keys[id] = depth;
    order[id] = id;
    uint o = id * SPLAT_RECORD;
    if (depth <= u_near_far.x || depth >= u_near_far.y) {
        proj[o + 3u] = 0.0;
        return;
    }
    mat3 w = mat3(u_view);
    mat3 r = splat_rotation(q);
    // view-space covariance W R S S^T R^T W^T, passed to the library as diagonal + off-diagonal
    mat3 m = w * r * mat3(sigma.x, 0.0, 0.0, 0.0, sigma.y, 0.0, 0.0, 0.0, sigma.z);
    mat3 c = m * transpose(m);
    vec3 cov2d = splat_cov2d(t_vs, vec3(c[0][0], c[1][1], c[2][2]),
                             vec3(c[1][0], c[2][0], c[2][1]), u_focal_tan);
    float det = splat_cov2d_det(t_vs, m[0], m[1], m[2], u_focal_tan);
    vec3 conic = splat_conic(cov2d, det);
    vec4 axes = splat_axes(cov2d, det);
    vec2 e1 = axes.zw;
    vec2 e2 = vec2(-e1.y, e1.x);
    vec4 clip = u_projection * vec4(t_vs, 1.0);
    vec2 centre = (clip.xy / clip.w * 0.5 + 0.5) * u_resolution;

    vec3 to_splat = mean - u_camera_ws;
    vec3 dir = normalize(to_splat);
    vec3 color = vec3(0.0);
    uint s = i * uint(u_sh_count) * 3u;
    for (int k = 0; k < u_sh_count; ++k) {
        uint b = s + uint(k) * 3u;
        color += splat_sh_basis(k, dir) * vec3(sh[b], sh[b + 1u], sh[b + 2u]);
    }
    color = max(color + 0.5, vec3(0.0));

    uint mt = i * 8u;
    vec3 n = vec3(mat[mt + 4u], mat[mt + 5u], mat[mt + 6u]);
    if (dot(n, n) <= 0.0) {
        n = r[sigma.x <= sigma.y ? (sigma.x <= sigma.z ? 0 : 2) : (sigma.y <= sigma.z ? 1 : 2)];
    }
    n = splat_face_forward(normalize(n), -to_splat);

    proj[o + 0u] = centre.x;
    proj[o + 1u] = centre.y;
    proj[o + 2u] = clip.z / clip.w;
    proj[o + 3u] = opacity;
    proj[o + 4u] = conic.x;
    proj[o + 5u] = conic.y;
    proj[o + 6u] = conic.z;
    // quad half-axes: sqrt(8) sigma, at most as long as the farthest pixel is from the centre (a
    // needle's 3e6 px axis would put the vertices where float rounding moves the quad's edges by
    // a quarter pixel), plus 1 px so rounding never cuts the footprint (the d^2 <= 8 test in
    // splat_raster.frag decides the covered pixels, not the quad)
    float reach = length(centre - 0.5 * u_resolution) + length(u_resolution);
    vec2 a1 = e1 * (min(sqrt(8.0 * axes.x), reach) + 1.0);
    vec2 a2 = e2 * (min(sqrt(8.0 * axes.y), reach) + 1.0);
    proj[o + 7u] = a1.x;
    proj[o + 8u] = a1.y;
    proj[o + 9u] = a2.x;
    proj[o + 10u] = a2.y;
    proj[o + 11u] = color.r;
    proj[o + 12u] = color.g;
    proj[o + 13u] = color.b;
    proj[o + 14u] = mat[mt];
    proj[o + 15u] = mat[mt + 1u];
    proj[o + 16u] = mat[mt + 2u];
    proj[o + 17u] = n.x;
    proj[o + 18u] = n.y;
    proj[o + 19u] = n.z;
    proj[o + 20u] = mat[mt + 3u];
    proj[o + 21u] = mat[mt + 7u];
    proj[o + 22u] = depth;
    proj[o + 23u] = 0.0;
}
