"""Shadow maps (``passes/shadow_mesh.vert``, ``shadow_splat.vert``, ``shadow.frag``): the depth of
the nearest occluder seen from a directional light, in the light's fitted frame
(:class:`viewer.shadows.ShadowFrame`), rendered from the scene's meshes and Gaussian splats.

Meshes are drawn with both faces (a closed mesh's back faces keep light from leaking through a
thin wall); the receiver's normal-offset bias (``shadow_receiver`` in ``lib/shadow.glsl``) keeps
lit surfaces from shadowing themselves. A splat is a quad over its projected 3-sigma ellipse in
the light's frame, cut where the Gaussian's opacity falls below 0.5, at its mean depth along each light ray: a
splat surface dense enough to look opaque casts a shadow, a haze of faint splats does not.
Transparent (alphaMode BLEND) meshes cast no shadow.
"""
from __future__ import annotations

import numpy as np

from ..geometry.mesh import Mesh
from ..shadows import ShadowFrame
from ..splats.data import Splats
from .uploads import UploadCache

SPLAT_FLOATS = 10  # center (3), conic (3), radius, opacity, depth slope (2)


def splat_shadow_instances(splats: Splats, frame: ShadowFrame) -> np.ndarray:
    """``[N, 10]`` float32 per-splat quads of ``splats`` in ``frame``: the centre's (u, v, depth),
    the inverse 2D covariance in texels^-2, the 3-sigma radius in texels, the opacity, and the
    depth's slope per texel of offset (the Gaussian's conditional mean depth along each light
    ray, Sigma_zuv Sigma_uv^-1: a flat splat lit at a slant is a slanted surface in the map, not
    one depth)."""
    m = frame.matrix
    centers = splats.means.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    j = m[:3, :3].copy()
    j[:2] *= float(frame.resolution)  # world -> (texels, texels, depth)
    cov3 = np.einsum("ij,njk,lk->nil", j, splats.covariances(), j)
    cov = cov3[:, :2, :2].copy()
    cov[:, 0, 0] += 0.3  # at least a third of a texel wide, as splat rasterisers dilate
    cov[:, 1, 1] += 0.3
    a, b, c = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    det = np.maximum(a * c - b * b, 1e-12)
    conic = np.stack([c / det, -b / det, a / det], axis=1)
    mid = 0.5 * (a + c)
    lam = mid + np.sqrt(np.maximum(mid * mid - det, 0.0))
    radius = 3.0 * np.sqrt(lam)
    zuv = cov3[:, 2, :2]  # covariance of depth with (u, v)
    slope = np.stack([zuv[:, 0] * conic[:, 0] + zuv[:, 1] * conic[:, 1],
                      zuv[:, 0] * conic[:, 1] + zuv[:, 1] * conic[:, 2]], axis=1)
    out = np.concatenate([centers, conic, radius[:, None],
                          np.asarray(splats.opacities, np.float64)[:, None], slope], axis=1)
    return np.ascontiguousarray(out, np.float32)


class ShadowPass:
    """Draws shadow maps; owns its mesh copies (positions only are read) and splat instances."""

    def __init__(self, programs):
        self.programs = programs
        self.ctx = programs.ctx
        # mesh -> (vertex array, position buffer, index buffer): positions only
        self.meshes = UploadCache(self.ctx, "shadow mesh uploads", release=_release_arrays)
        # (cloud, frame matrix) -> (vertex array, instance buffer): rebuilt when the light turns
        self.splats = UploadCache(self.ctx, "splat shadow instances", max_items=4,
                                  release=_release_arrays)

    def _mesh_program(self):
        return self.programs.graphics("passes/shadow_mesh.vert", "passes/shadow.frag")

    def _splat_program(self):
        return self.programs.graphics("passes/shadow_splat.vert", "passes/shadow.frag",
                                      defines={"SPLAT": 1})

    def draw(self, target, frame: ShadowFrame, meshes: list[Mesh], clouds: list[Splats]) -> None:
        """Clear ``target`` (a :class:`~viewer.graph.resources.ShadowTarget`) to depth 1 and draw
        ``meshes`` and ``clouds`` into it."""
        ctx = self.ctx
        target.fbo.use()
        n = int(frame.resolution)
        ctx.viewport = (0, 0, n, n)
        target.fbo.clear(1.0, 1.0, 1.0, 1.0, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE | ctx.BLEND)
        matrix = np.ascontiguousarray(frame.matrix.T, np.float32).tobytes()
        try:
            for mesh in meshes:
                if mesh.alpha_mode == "BLEND":
                    continue
                vao = self._mesh_array(mesh)
                vao.program["u_light_matrix"].write(matrix)
                vao.render(ctx.TRIANGLES)
            for cloud in clouds:
                if len(cloud) == 0:
                    continue
                vao = self._splat_array(cloud, frame)
                vao.program["u_map_size"].value = (float(n), float(n))
                vao.render(ctx.TRIANGLE_STRIP, vertices=4, instances=len(cloud))
        finally:
            ctx.disable(ctx.DEPTH_TEST)

    def _mesh_array(self, mesh: Mesh):
        """The mesh's positions and indices with the shadow program (remade if the program was
        evicted and compiled again)."""
        prog = self._mesh_program()
        entry = self.meshes.get(mesh)
        if entry is None or entry[0].program is not prog:
            mesh.validated()
            pos = self.ctx.buffer(np.ascontiguousarray(mesh.positions, np.float32).tobytes())
            idx = self.ctx.buffer(np.ascontiguousarray(mesh.indices, np.uint32).tobytes())
            vao = self.ctx.vertex_array(prog, [(pos, "3f", "in_position")], index_buffer=idx,
                                        index_element_size=4)
            entry = self.meshes.put(mesh, None, (vao, pos, idx), pos.size + idx.size)
        return entry[0]

    def _splat_array(self, cloud: Splats, frame: ShadowFrame):
        key = (frame.matrix.tobytes(), frame.resolution)
        prog = self._splat_program()
        entry = self.splats.get(cloud, key)
        if entry is None or entry[0].program is not prog:
            data = splat_shadow_instances(cloud, frame)
            buf = self.ctx.buffer(data.tobytes())
            vao = self.ctx.vertex_array(prog, [(buf, "3f 3f 1f 1f 2f/i", "in_center", "in_conic",
                                                "in_radius", "in_opacity", "in_slope")])
            entry = self.splats.put(cloud, key, (vao, buf), buf.size)
        return entry[0]

    def release(self) -> None:
        self.meshes.release()
        self.splats.release()


def _release_arrays(value) -> None:
    """Release a (vertex array, buffers...) tuple, the vertex array first."""
    for obj in value:
        obj.release()
