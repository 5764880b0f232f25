// gbuffer_mesh.frag - G-buffer fill for triangle meshes: the glTF surface of mesh_surface.glsl
// (alphaMode OPAQUE and MASK; BLEND surfaces are shaded by the forward pass after lighting:
// viewer/passes/forward.py).
// Defines: those of mesh_surface.glsl, and ALPHA_MASK (glTF alphaMode MASK: fragments whose alpha
// is below u_alpha_cutoff are discarded).
#define GBUFFER_WRITE
#include "generated/gbuffer.glsl"
#include "passes/mesh_surface.glsl"

#ifdef ALPHA_MASK
uniform float u_alpha_cutoff;       // glTF alphaCutoff
#endif

void main() {
    float alpha;
    GBuffer g = mesh_surface(alpha);
#ifdef ALPHA_MASK
    // after every lookup (mesh_surface): derivatives are only defined while all fragments of a
    // quad run
    if (alpha < u_alpha_cutoff) {
        discard;
    }
#endif
    gbuffer_store(g);
}
