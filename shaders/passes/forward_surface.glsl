// forward_surface.glsl - the forward pass's G-buffer access (glTF alphaMode BLEND). The forward
// pass compiles a model's own lighting pass (shade_<model>.frag) unchanged, with this in place of
// the generated gbuffer_load: instead of reading the opaque G-buffer at `pixel`, it returns the
// blended surface at this fragment (mesh_surface.glsl) with coverage = its glTF alpha, so the
// pass's write_radiance(c, background, alpha) with BACKGROUND_ENVIRONMENT 0 writes the
// premultiplied colour (c alpha, alpha) that the fixed-function blend (ONE, ONE_MINUS_SRC_ALPHA)
// puts "over" the shaded radiance. Same shading code as the deferred pass by construction.
// The fragment is discarded where the opaque G-buffer (meshes, image stacks, splats) is nearer:
// a depth test against its depth channel (gbuffer_load_opaque, the generated loader renamed by
// viewer/passes/forward.py), which the forward pass never writes.
// Included by the virtual generated/gbuffer.glsl of viewer/passes/forward.py, after the layout's
// struct and loader.
#include "passes/mesh_surface.glsl"

GBuffer gbuffer_load(ivec2 pixel) {
    float alpha;
    GBuffer g = mesh_surface(alpha);  // every texture lookup first (derivatives), then discard
    GBuffer opaque = gbuffer_load_opaque(pixel);
    if (opaque.alpha > 0.0 && !(g.depth < opaque.depth)) {
        discard;  // behind (or at) the opaque surface of this pixel
    }
    g.alpha = clamp(alpha, 0.0, 1.0);
    g.color = g.albedo * g.alpha;  // the unlit colour channel is premultiplied by coverage
    return g;
}
