// equirect.glsl - equirectangular (latitude-longitude) mapping and environment rotation.
// Convention (project-wide): image row 0 is the zenith (+Y). uv in [0,1]^2, u across columns,
// v down rows; phi = 2 pi (u - 0.5), theta = pi v (polar angle from +Y);
// dir = (sin(theta) sin(phi), cos(theta), -sin(theta) cos(phi)): u = 0.5 is -Z, u = 0.75 is +X.
// GL textures are uploaded with row 0 first and sampled at t = v (no flip). No uniforms, no main.
#include "lib/common.glsl"

// Inverse of equirect_dir: u = atan(x, -z) / 2pi + 0.5, v = acos(y) / pi. v is computed as
// atan(|xz|, y) / pi (the same angle, but well conditioned at the poles where acos is not).
// dir need not be normalised; at the poles (|xz| <= 1e-18) u is 0.5: below that x^2 + z^2 can
// be a denormal, which a GPU may flush to zero (an H200 did: u 0.5 where atan gave 0.75).
vec2 equirect_uv(vec3 dir) {
    float rho = length(dir.xz);
    float phi = rho > 1e-18 ? atan(dir.x, -dir.z) : 0.0;
    float theta = atan(rho, dir.y);
    return vec2(phi * (0.5 * INV_PI) + 0.5, theta * INV_PI);
}

// Unit direction for equirect coordinates uv (see the file header).
vec3 equirect_dir(vec2 uv) {
    float phi = TWO_PI * (uv.x - 0.5);
    float theta = PI * uv.y;
    float sin_theta = sin(theta);
    return vec3(sin_theta * sin(phi), cos(theta), -sin_theta * cos(phi));
}

// Rotation about +Y by angle radians, counter-clockwise seen from above (right-hand rule).
// An environment rotated by theta is looked up at rotate_y(d, -theta).
vec3 rotate_y(vec3 v, float angle) {
    float c = cos(angle);
    float s = sin(angle);
    return vec3(c * v.x + s * v.z, v.y, -s * v.x + c * v.z);
}
