// gbuffer_mesh.vert - G-buffer fill for triangle meshes whose vertices are already in world space.
// Defines: USE_UV0 / USE_UV1 (a texture map reads texture coordinate set 0 / 1), HAS_TANGENTS
// (vertex tangents for the normal map), USE_VERTEX_COLOR (glTF COLOR_0); FORWARD (the forward pass
// for alphaMode BLEND, whose fragment stage is a lighting pass: it also writes deferred.glsl's v_uv).
uniform mat4 u_view;        // world -> view
uniform mat4 u_projection;  // view -> clip

in vec3 in_position;  // world space
in vec3 in_normal;    // world space, unit
#ifdef USE_UV0
in vec2 in_uv0;       // glTF convention: (0, 0) at the top-left of the image
out vec2 v_uv0;
#endif
#ifdef USE_UV1
in vec2 in_uv1;
out vec2 v_uv1;
#endif
#ifdef HAS_TANGENTS
in vec4 in_tangent;   // xyz world space, w = bitangent sign (glTF)
out vec4 v_tangent_ws;
#endif
#ifdef USE_VERTEX_COLOR
in vec4 in_color;     // linear RGBA
out vec4 v_color;
#endif

#ifdef FORWARD
out vec2 v_uv;  // deferred.glsl declares the fullscreen pass's uv; no lighting pass reads it
#endif

out vec3 v_position_ws;
out vec3 v_normal_ws;
out float v_depth_vs;  // -z_vs: positive distance along the view axis

void main() {
    vec4 p_vs = u_view * vec4(in_position, 1.0);
    v_position_ws = in_position;
    v_normal_ws = in_normal;
    v_depth_vs = -p_vs.z;
#ifdef USE_UV0
    v_uv0 = in_uv0;
#endif
#ifdef USE_UV1
    v_uv1 = in_uv1;
#endif
#ifdef HAS_TANGENTS
    v_tangent_ws = in_tangent;
#endif
#ifdef USE_VERTEX_COLOR
    v_color = in_color;
#endif
    gl_Position = u_projection * p_vs;
#ifdef FORWARD
    v_uv = gl_Position.xy / gl_Position.w * 0.5 + 0.5;
#endif
}
