// shadow_mesh.vert - a shadow map of triangle meshes (world-space vertices): each vertex to the
// light's frame, (u, v, depth) in [0, 1]^3 (viewer/shadows.py ShadowFrame.matrix).
uniform mat4 u_light_matrix;  // world -> (u, v, depth, 1)

in vec3 in_position;  // world space
out float v_depth;

void main() {
    vec3 s = (u_light_matrix * vec4(in_position, 1.0)).xyz;
    v_depth = s.z;
    gl_Position = vec4(s * 2.0 - 1.0, 1.0);
}
