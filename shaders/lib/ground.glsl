// ground.glsl - the shadow-catcher ground (model-viewer's ground shadow, Blender's shadow
// catcher): a plane that shows only the light it loses to occluders, multiplied onto the
// environment behind it, and that fades into the environment with distance so that its edge is
// never seen. Pure functions; which pixels are the catcher is ground_catcher in
// passes/ground.glsl. Twins: learned/twins/ground.py.

// How much of the catcher shows at distance r from its centre: 1 within r_start, 0 from r_end
// on, a smoothstep between (r_start < r_end).
float ground_fade(float r, float r_start, float r_end) {
    return 1.0 - smoothstep(r_start, r_end, r);
}

// The catcher's radiance: the environment behind it (background) times the share of the
// ground's light that reaches it, the luminance ratio of its shaded radiance (shadows, occlusion)
// to its unshadowed radiance, clamped to [0, 1] (1 where nothing occludes it); `fade` (from
// ground_fade) blends that share to 1, the bare environment.
vec3 ground_catcher_radiance(vec3 shaded, vec3 unshadowed, vec3 background, float fade) {
    const vec3 luma = vec3(0.2126, 0.7152, 0.0722);  // Rec. 709
    float seen = clamp(dot(shaded, luma) / max(dot(unshadowed, luma), 1e-8), 0.0, 1.0);
    return background * mix(1.0, seen, fade);
}
