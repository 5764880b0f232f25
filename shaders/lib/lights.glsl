// lights.glsl - punctual lights (the scene file's [[lights]] and [light], glTF KHR_lights_punctual):
// the unit direction from a surface point towards a light and the factor on the light's
// colour x intensity that gives the irradiance on a surface facing it. Pure functions; the uniforms
// and the per-model loops are in passes/lights.glsl. Conventions (docs/explanation/conventions.md):
// a directional light's intensity is its irradiance (W/m^2), a point or spot light's its radiant
// intensity (W/sr); glTF's photometric units are taken as these radiometric ones (no 683 lm/W).
#include "lib/common.glsl"

#define LIGHT_TYPE_DIRECTIONAL 0
#define LIGHT_TYPE_POINT 1
#define LIGHT_TYPE_SPOT 2

// glTF's recommended range window (KHR_lights_punctual): clamp(1 - (d / range)^4, 0, 1)^2, which
// takes a light smoothly to 0 at `range`; range <= 0 means no range (1 everywhere).
float light_range_window(float d, float range) {
    if (!(range > 0.0)) return 1.0;
    float q = d / range;
    q *= q;
    return sq(saturate(1.0 - q * q));
}

// glTF's spot cone (KHR_lights_punctual's reference implementation): 1 inside the inner cone, 0
// outside the outer one, t^2 between with t linear in the cosine of the angle to the axis:
// t = saturate((cos_angle - cos_outer) / max(cos_inner - cos_outer, 1e-3)).
float spot_cone_factor(float cos_angle, float cos_outer, float cos_inner) {
    float t = saturate((cos_angle - cos_outer) / max(cos_inner - cos_outer, 1e-3));
    return t * t;
}

// Light `type` (LIGHT_TYPE_*) at surface point p (world space). position: the light's (point,
// spot); direction: unit, towards the light (directional: where it comes from; spot: its axis
// reversed, from the lit centre back to the light); cone_range = (cos outer, cos inner, range
// (<= 0: none), unused). Returns (l, attenuation): l the unit direction from p towards the light,
// attenuation 1 (directional), window(d) / d^2 (point), times the cone factor (spot); 0 at d = 0.
vec4 punctual_light(int type, vec3 position, vec3 direction, vec4 cone_range, vec3 p) {
    if (type == LIGHT_TYPE_DIRECTIONAL) return vec4(direction, 1.0);
    vec3 to_light = position - p;
    float d2 = dot(to_light, to_light);
    if (!(d2 > 0.0)) return vec4(direction, 0.0);
    float d = sqrt(d2);
    vec3 l = to_light / d;
    float attenuation = light_range_window(d, cone_range.z) / d2;
    if (type == LIGHT_TYPE_SPOT) {
        attenuation *= spot_cone_factor(dot(l, direction), cone_range.x, cone_range.y);
    }
    return vec4(l, attenuation);
}
