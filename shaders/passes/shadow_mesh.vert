// shadow_mesh.vert - a shadow map of triangle meshes (world-space vertices): each vertex to the
// light's frame (viewer/lighting/shadow_frames.py ShadowFrame.matrix): (u w, v w, depth, w), w = 1 for an
// orthographic map, the distance along the axis for a perspective one. depth is linear in world
// space, so its perspective-correct interpolation is exact. RADIAL (a point light's cube faces):
// shadow.frag writes the distance from the light instead.
#ifndef RADIAL
#define RADIAL 0
#endif
uniform mat4 u_light_matrix;  // world -> (u w, v w, depth, w)

in vec3 in_position;  // world space
out float v_depth;
#if RADIAL
uniform vec3 u_light_center;  // world space
out vec3 v_from_light;
#endif

void main() {
    vec4 h = u_light_matrix * vec4(in_position, 1.0);
    v_depth = h.z;
#if RADIAL
    v_from_light = in_position - u_light_center;
#endif
    gl_Position = vec4(h.xy * 2.0 - h.w, (h.z * 2.0 - 1.0) * h.w, h.w);
}
