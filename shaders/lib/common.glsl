// common.glsl - constants and small helpers shared by every library file. No uniforms, no main.
#ifndef PI
#define PI 3.14159265358979323846
#define INV_PI 0.31830988618379067154
#define TWO_PI 6.28318530717958647692
#endif

// Clamp to [0, 1]; HLSL's name, used by the BRDF literature.
float saturate(float x) { return clamp(x, 0.0, 1.0); }

// Squared length without the square root; used for |n x h|^2 style expressions.
float sq(float x) { return x * x; }

// The normalised half vector of v and l (the microfacet normal reflecting l into v; the PBND
// teacher's specular input, thesis fig. 4.5); +Z where v = -l and it is undefined.
vec3 half_vector(vec3 v, vec3 l) {
    vec3 h = v + l;
    float len2 = dot(h, h);
    return len2 > 1e-30 ? h * inversesqrt(len2) : vec3(0.0, 0.0, 1.0);
}
