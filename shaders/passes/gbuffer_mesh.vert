// gbuffer_mesh.vert - G-buffer fill for triangle meshes whose vertices are already in world space.
// Defines: USE_UV (any texture map), HAS_TANGENTS (vertex tangents for the normal map).
uniform mat4 u_view;        // world -> view
uniform mat4 u_projection;  // view -> clip

in vec3 in_position;  // world space
in vec3 in_normal;    // world space, unit
#ifdef USE_UV
in vec2 in_uv;        // glTF convention: (0, 0) at the top-left of the image
out vec2 v_uv;
#endif
#ifdef HAS_TANGENTS
in vec4 in_tangent;   // xyz world space, w = bitangent sign (glTF)
out vec4 v_tangent_ws;
#endif

out vec3 v_position_ws;
out vec3 v_normal_ws;
out float v_depth_vs;  // -z_vs: positive distance along the view axis

void main() {
    vec4 p_vs = u_view * vec4(in_position, 1.0);
    v_position_ws = in_position;
    v_normal_ws = in_normal;
    v_depth_vs = -p_vs.z;
#ifdef USE_UV
    v_uv = in_uv;
#endif
#ifdef HAS_TANGENTS
    v_tangent_ws = in_tangent;
#endif
    gl_Position = u_projection * p_vs;
}
