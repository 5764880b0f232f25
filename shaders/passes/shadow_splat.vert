// shadow_splat.vert - a shadow map of Gaussian splats: one quad per splat (instanced), covering
// its projected 3-sigma ellipse in the light's frame; shadow.frag (SPLAT) cuts it to where the
// Gaussian is opaque enough. Per-instance data is made on the CPU (viewer/passes/shadow.py).
uniform vec2 u_map_size;   // texels

in vec3 in_center;         // (u, v, depth) of the splat's centre
in vec3 in_conic;          // inverse 2D covariance in texels^-2: (a, b, c)
in float in_radius;        // texels: 3 sigma of the major axis
in float in_opacity;
in vec2 in_slope;          // depth per texel of offset: the Gaussian's mean depth along a ray
out float v_depth;
out vec2 v_offset;
flat out vec3 v_conic;
flat out float v_opacity;

void main() {
    vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1)) * 2.0 - 1.0;
    v_offset = corner * in_radius;
    v_conic = in_conic;
    v_opacity = in_opacity;
    v_depth = in_center.z + dot(in_slope, v_offset);
    vec2 uv = in_center.xy + v_offset / u_map_size;
    gl_Position = vec4(uv * 2.0 - 1.0, clamp(v_depth, 0.0, 1.0) * 2.0 - 1.0, 1.0);
}
