// splat_raster.vert - one instanced quad per splat (4-vertex triangle strip), drawn in the order
// given by u_order (back to front). The quad spans +-sqrt(8) sigma (capped at the farthest pixel,
// plus 1 px: see splat_project.comp) along the 2D eigen axes; all its
// vertices sit at the splat centre's depth, so the depth test against meshes is per splat.
layout(std430, binding = 0) readonly buffer Projected { float proj[]; };  // from splat_project
layout(std430, binding = 1) readonly buffer Order { uint order[]; };

uniform vec2 u_resolution;

flat out vec2 v_centre;     // pixels, GL origin
flat out vec3 v_conic;
flat out float v_opacity;
flat out vec3 v_color;
flat out vec3 v_albedo;
flat out vec3 v_normal_ws;
flat out vec3 v_rmd;        // roughness, metallic, depth

void main() {
    uint o = order[gl_InstanceID] * SPLAT_RECORD;
    v_opacity = proj[o + 3u];
    if (v_opacity <= 0.0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // culled: outside the clip volume
        return;
    }
    vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1)) * 2.0 - 1.0;
    v_centre = vec2(proj[o], proj[o + 1u]);
    v_conic = vec3(proj[o + 4u], proj[o + 5u], proj[o + 6u]);
    v_color = vec3(proj[o + 11u], proj[o + 12u], proj[o + 13u]);
    v_albedo = vec3(proj[o + 14u], proj[o + 15u], proj[o + 16u]);
    v_normal_ws = vec3(proj[o + 17u], proj[o + 18u], proj[o + 19u]);
    v_rmd = vec3(proj[o + 20u], proj[o + 21u], proj[o + 22u]);
    vec2 p = v_centre + corner.x * vec2(proj[o + 7u], proj[o + 8u])
                      + corner.y * vec2(proj[o + 9u], proj[o + 10u]);
    gl_Position = vec4(p / u_resolution * 2.0 - 1.0, proj[o + 2u], 1.0);
}
