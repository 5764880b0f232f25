// contact.glsl - screen-space contact shadows (Filament's: a short march through the depth buffer
// from a surface point towards a light; what the buffer shows in front of the march occludes).
// The only shadows an image-space stack can have (no shadow map holds its surfaces), and
// small-scale detail a map's texels miss on meshes. Pure functions; the march over the G-buffer
// is contact_shadow in passes/lights.glsl. Twins: learned/twins/contact.py.
#include "lib/common.glsl"

// A world point's pixel coordinates (gl_FragCoord units: (0, 0) the bottom-left corner) and view
// depth (positive distance along the view axis) for a camera at camera_pos whose frame's axes
// are right, up and back (world space), tan_half_fov = (tan(fov_x / 2), tan(fov_y / 2)), a
// framebuffer of `resolution` pixels.
vec3 contact_project(vec3 p_ws, vec3 right, vec3 up, vec3 back, vec3 camera_pos,
                     vec2 tan_half_fov, vec2 resolution) {
    vec3 d = p_ws - camera_pos;
    vec3 v = vec3(dot(d, right), dot(d, up), dot(d, back));
    float depth = -v.z;
    vec2 ndc = v.xy / (max(depth, 1e-6) * tan_half_fov);
    return vec3((ndc * 0.5 + 0.5) * resolution, depth);
}

// 1 when a march sample at view depth ray_depth lies behind the surface the depth buffer holds
// at its pixel (scene_depth; 0 = background, nothing) by more than bias (the buffer's own
// discretisation) and less than thickness (what the buffer shows is assumed this thick: a sample
// farther behind passes behind the object), else 0.
float contact_occluded(float ray_depth, float scene_depth, float bias, float thickness) {
    float d = ray_depth - scene_depth;
    return scene_depth > 0.0 && d > bias && d < thickness ? 1.0 : 0.0;
}

// A pixel's offset of the march's samples along the ray, in [0, 1) steps: interleaved gradient
// noise (Jimenez 2014) of its fragment coordinates, so step-sized bands become noise.
float contact_jitter(vec2 frag_coord) {
    return fract(52.9829189 * fract(dot(frag_coord, vec2(0.06711056, 0.00583715))));
}
