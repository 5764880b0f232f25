"""Shadow maps (``passes/shadow_mesh.vert``, ``shadow_splat.vert``, ``shadow.frag``): the depth of
the nearest occluder seen from a light, in the light's fitted frame
(:class:`viewer.lighting.shadow_frames.ShadowFrame`: orthographic for directional lights, perspective for spot
lights; a point light's :class:`~viewer.lighting.shadow_frames.ShadowCube` is six perspective faces drawn into the
tiles of one atlas), rendered from the scene's meshes and Gaussian splats.

A mesh that bounds a solid (:func:`viewer.geometry.solid.solid_orientation`) is drawn with only its
faces turned towards the light, which hold the nearest occluder of every ray from a light outside it
(a light inside its bounds, or an open mesh: both faces, which keep light from leaking through a
thin wall): the same map for half the rasterised triangles. The receiver's normal-offset bias
(``shadow_receiver`` in ``lib/shadow.glsl``) keeps lit surfaces from shadowing themselves. A splat
is a quad over its projected 3-sigma ellipse in the light's frame, cut where the Gaussian's opacity
falls below 0.5, at its mean depth along each light ray: a splat surface dense enough to look opaque
casts a shadow, a haze of faint splats does not. Transparent (alphaMode BLEND) meshes cast no
shadow.

Each mesh is drawn at the coarsest level of detail (:mod:`viewer.geometry.simplify`) whose error
is at most ``lod_error`` texels of the map where the mesh lies (``[render]
shadow_lod_error``, 0.5 by default; 0: whole meshes): the map cannot resolve the difference,
and a software rasteriser's shadow pass costs per triangle. A map's meshes are drawn in one call
per way of culling them, their levels joined into one buffer (kept for that set of meshes and
levels): a software rasteriser pays for each draw call too."""
from __future__ import annotations

import numpy as np

from ..geometry.mesh import Mesh
from ..geometry.simplify import SimplifiedMesh, lod_level, simplify, whole
from ..geometry.solid import OPEN, OUTWARD, plane_of
from ..lighting.cascades import ShadowCascades
from ..lighting.lights import MAX_LIGHTS
from ..lighting.shadow_frames import (
    SHADOW_ORTHO,
    EnvShadowFrames,
    ShadowCube,
    ShadowFrame,
)
from ..scene.bounds import Bounds
from ..splats.data import Splats
from .uploads import UploadCache

# caster sets ShadowPass.batches keeps: a set per cube face and way of culling (front, back,
# neither) for MAX_LIGHTS point lights, and 64 more for the sun's, the environment's lights' and
# its directions' maps: a frame's every set stays uploaded, none is made again each frame
MAX_BATCHES = MAX_LIGHTS * 6 * 3 + 64
SPLAT_FLOATS = 10  # center (3), conic (3), radius, opacity, depth slope (2)


def splat_shadow_instances(splats: Splats, frame: ShadowFrame) -> np.ndarray:
    """``[N, 10]`` float32 per-splat quads of ``splats`` in ``frame``: the centre's (u, v, depth),
    the inverse 2D covariance in texels^-2, the 3-sigma radius in texels, the opacity, and the
    depth's slope per texel of offset (the Gaussian's conditional mean depth along each light
    ray, Sigma_zuv Sigma_uv^-1: a flat splat lit at a slant is a slanted surface in the map, not
    one depth). A perspective frame is taken as its affine approximation at each splat's centre
    (:meth:`~viewer.lighting.shadow_frames.ShadowFrame.jacobian`, as EWA splatting projects a Gaussian); splats
    behind a perspective frame's light get opacity 0 (drawn nowhere)."""
    means = splats.means.astype(np.float64)
    centers = frame.project(means)
    j = frame.jacobian(means)  # [N, 3, 3]
    j[:, :2] *= float(frame.resolution)  # world -> (texels, texels, depth)
    cov3 = np.einsum("nij,njk,nlk->nil", j, splats.covariances(), j)
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
    opacity = np.asarray(splats.opacities, np.float64).copy()
    w = np.concatenate([means, np.ones((len(means), 1))], axis=1) @ frame.matrix[3]
    behind = ~(w > 1e-9) | ~np.isfinite(centers).all(axis=1)
    opacity[behind] = 0.0
    radius[behind] = 0.0
    out = np.concatenate([np.where(behind[:, None], 0.0, centers), conic, radius[:, None],
                          opacity[:, None], slope], axis=1)
    return np.ascontiguousarray(np.nan_to_num(out), np.float32)


class ShadowPass:
    """Draws shadow maps; owns its mesh copies (positions only are read) and splat instances."""

    def __init__(self, programs):
        self.programs = programs
        self.ctx = programs.ctx
        # (mesh, level) -> its SimplifiedMesh (level None: the whole mesh), or None where a level
        # saves too little (the whole mesh is drawn): shared by the programs that draw it
        self.casters = UploadCache(self.ctx, "shadow caster levels", release=lambda value: None)
        self.triangles = 0  # mesh triangles drawn into maps since created (a caller may reset it)
        # (meshes, (variant, levels)) -> (vertex array, position buffer, index buffer): the
        # casters of a map drawn in one call (_batch_array), one mesh or several; at most
        # MAX_BATCHES sets, and bounded also by the meshes' lifetime and geometry budget
        self.batches = UploadCache(self.ctx, "shadow caster batches", max_items=MAX_BATCHES,
                                   release=_release_arrays)
        # (cloud, frame matrix) -> (vertex array, instance buffer): rebuilt when the light turns
        self.splats = UploadCache(self.ctx, "splat shadow instances", max_items=16,
                                  release=_release_arrays)

    def _mesh_program(self, variant: str = "ortho"):
        """``variant``: "ortho" (the rasterised depth is the map's: no gl_FragDepth),
        "perspective" (linear depth written per fragment) or "radial" (cube faces)."""
        defines = {"ortho": {"WRITE_DEPTH": 0}, "perspective": {},
                   "radial": {"RADIAL": 1}}[variant]
        return self.programs.graphics("passes/shadow_mesh.vert", "passes/shadow.frag",
                                      defines=defines)

    def _splat_program(self):
        return self.programs.graphics("passes/shadow_splat.vert", "passes/shadow.frag",
                                      defines={"SPLAT": 1})

    def draw(self, target, frame: ShadowFrame | ShadowCube, meshes: list[Mesh],
             clouds: list[Splats], lod_error: float = 0.0,
             flat_receivers: bool = False) -> None:
        """Clear ``target`` (a :class:`~viewer.graph.resources.ShadowTarget`) to depth 1 and draw
        ``meshes`` and ``clouds`` into it (a cube, cascades or the environment's directions: into
        each face's, cascade's or direction's tile); each mesh at the coarsest level of detail
        whose error is at most ``lod_error`` of the tile's texels where it lies (0: whole).
        ``flat_receivers``: ``meshes`` and ``clouds`` are every surface that reads the map, so a
        flat mesh that hides none of them from the light (:func:`occludes_nothing`: a floor under
        the scene, lit from above) is left out."""
        ctx = self.ctx
        target.fbo.use()
        ctx.viewport = (0, 0, *target.texture.size)
        target.fbo.clear(1.0, 1.0, 1.0, 1.0, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE | ctx.BLEND)
        ctx.front_face = "ccw"
        try:
            if isinstance(frame, (ShadowCube, ShadowCascades, EnvShadowFrames)):
                for face, f in enumerate(frame.faces):
                    ctx.viewport = frame.tile(face)
                    self._draw_frame(f, meshes, clouds, lod_error, flat_receivers)
            else:
                ctx.viewport = (0, 0, frame.resolution, frame.resolution)
                self._draw_frame(frame, meshes, clouds, lod_error, flat_receivers)
        finally:
            ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
            ctx.cull_face = "back"

    def _draw_frame(self, frame: ShadowFrame, meshes: list[Mesh], clouds: list[Splats],
                    lod_error: float = 0.0, flat_receivers: bool = False) -> None:
        n = int(frame.resolution)
        radial = frame.center is not None
        variant = "radial" if radial else ("ortho" if frame.kind == SHADOW_ORTHO
                                           else "perspective")
        matrix = np.ascontiguousarray(frame.matrix.T, np.float32).tobytes()
        facing, origin = frame.facing_winding(), frame.origin
        # every caster's and surface's box (transparent meshes receive shadows too), for the
        # flat meshes that hide nothing in this frame
        boxes = [self._whole(m)[1] for m in meshes] + [self._cloud_box(c) for c in clouds
                                                        if len(c)] if flat_receivers else []
        batches: dict = {}  # faces culled -> [(mesh, level, caster)]: one draw each
        for k, mesh in enumerate(meshes):
            if mesh.alpha_mode == "BLEND":
                continue
            _, box, plane = self._whole(mesh)
            if plane is not None and flat_receivers and occludes_nothing(
                    plane, frame, boxes[:k] + boxes[k + 1:], box):
                continue
            level = None if lod_error <= 0.0 else lod_level(
                float(np.max(box[1] - box[0])), lod_error * frame.texel_at(box))
            caster, level = self._caster(mesh, level)
            if len(caster.indices) == 0:
                continue
            cull = culled_faces(caster.orientation, facing, box, origin)
            batches.setdefault(cull, []).append((mesh, level, caster))
        for cull, batch in batches.items():
            vao, triangles = self._batch_array(batch, variant)
            if cull is None:
                self.ctx.disable(self.ctx.CULL_FACE)
            else:
                self.ctx.enable(self.ctx.CULL_FACE)
                self.ctx.cull_face = cull
            vao.program["u_light_matrix"].write(matrix)
            if radial:
                vao.program["u_light_center"].value = frame.center
                vao.program["u_near_range"].value = (frame.near, frame.depth_range)
            vao.render(self.ctx.TRIANGLES)
            self.triangles += triangles
        for cloud in clouds:
            if len(cloud) == 0:
                continue
            vao = self._splat_array(cloud, frame)
            vao.program["u_map_size"].value = (float(n), float(n))
            vao.render(self.ctx.TRIANGLE_STRIP, vertices=4, instances=len(cloud))

    def _batch_array(self, batch: list, variant: str):
        """One vertex array drawing every (mesh, level, caster) of ``batch`` (the casters of a
        map whose faces are culled alike) with the program of ``variant`` (:meth:`_mesh_program`;
        remade if the program was evicted and compiled again), and its triangle count: the
        casters' levels joined into one buffer, made once for that set of meshes at those
        levels (a software rasteriser pays for each draw call: the bench's four maps of ten
        spheres take about a third less time drawn this way than one call a sphere)."""
        prog = self._mesh_program(variant)
        parts = tuple(mesh for mesh, _, _ in batch)
        key = (variant, tuple(level for _, level, _ in batch))
        entry = self.batches.get(parts, key)
        if entry is None or entry[0].program is not prog:
            casters = [caster for _, _, caster in batch]
            starts = np.cumsum([0] + [len(c.positions) for c in casters[:-1]])
            pos = np.concatenate([np.asarray(c.positions, np.float32).reshape(-1, 3)
                                  for c in casters])
            idx = np.concatenate([np.asarray(c.indices, np.int64).reshape(-1, 3) + start
                                  for c, start in zip(casters, starts)]).astype(np.uint32)
            pbuf = self.ctx.buffer(np.ascontiguousarray(pos).tobytes())
            ibuf = self.ctx.buffer(np.ascontiguousarray(idx).tobytes())
            vao = self.ctx.vertex_array(prog, [(pbuf, "3f", "in_position")], index_buffer=ibuf,
                                        index_element_size=4)
            entry = self.batches.put(parts, key, (vao, pbuf, ibuf), pbuf.size + ibuf.size)
        return entry[0], entry[2].size // 12  # 3 uint32 indices a triangle

    def _caster(self, mesh: Mesh, level: int | None) -> tuple[SimplifiedMesh, int | None]:
        """The mesh at ``level`` (None: whole) and the level it is drawn at: None where the
        level would keep most of its triangles (:func:`~viewer.geometry.simplify.simplify`)."""
        if level is not None:
            found = self.casters.get(mesh, level)
            if found is None:
                simplified = simplify(mesh.positions, mesh.indices, level)
                found = self.casters.put(mesh, level, (simplified,),
                                         simplified.nbytes if simplified is not None else 0)
            if found[0] is not None:
                return found[0], level
        return self._whole(mesh)[0], None

    def _whole(self, mesh: Mesh) -> tuple[SimplifiedMesh, tuple, tuple | None]:
        """The whole mesh as a caster, its bounds and its plane where it is flat
        (:func:`~viewer.geometry.solid.plane_of`): found once a mesh, not on each draw."""
        found = self.casters.get(mesh, None)
        if found is None:
            mesh.validated()
            found = self.casters.put(mesh, None, (whole(mesh.positions, mesh.indices),
                                                  mesh.bounds(), plane_of(mesh.positions)),
                                     0)  # the mesh's own arrays
        return found

    def _cloud_box(self, cloud: Splats) -> tuple[np.ndarray, np.ndarray]:
        """Every splat's 3-sigma box (not the robust bounds that frame a camera: an outlier
        below a floor still receives its shadow), found once a cloud."""
        found = self.casters.get(cloud, "box")
        if found is None:
            means = np.asarray(cloud.means, np.float64).reshape(-1, 3)
            grow = 3.0 * np.asarray(cloud.scales, np.float64).reshape(-1, 3).max(axis=1,
                                                                                keepdims=True)
            ok = np.isfinite(means).all(axis=1) & np.isfinite(grow[:, 0])
            lo = (means - grow)[ok].min(axis=0) if ok.any() else np.zeros(3)
            hi = (means + grow)[ok].max(axis=0) if ok.any() else np.zeros(3)
            found = self.casters.put(cloud, "box", (lo, hi), 0)
        return found

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
        self.batches.release()
        self.casters.release()
        self.splats.release()


def culled_faces(orientation: int, facing: str, bounds, origin) -> str | None:
    """The faces (``"front"`` or ``"back"``, GL's counter-clockwise front) a shadow pass culls
    from a mesh of :func:`~viewer.geometry.solid.solid_orientation` ``orientation`` and
    ``bounds`` (lo, hi): those turned away from the light, whose faces turned towards it wind
    ``facing`` in the map (:meth:`~viewer.lighting.shadow_frames.ShadowFrame.facing_winding`); None (both
    faces drawn) for an open mesh or a light at ``origin`` inside the mesh's bounds (a lamp in
    a room: its rays leave the solid first)."""
    if orientation == OPEN:
        return None
    if origin is not None:
        lo, hi = bounds
        if np.all(np.asarray(origin) >= lo) and np.all(np.asarray(origin) <= hi):
            return None
    # an outward solid's faces towards the light are counter-clockwise about their normals
    keep_ccw = (facing == "ccw") == (orientation == OUTWARD)
    return "back" if keep_ccw else "front"


def occludes_nothing(plane, frame: ShadowFrame, boxes, own_box) -> bool:
    """Whether a flat mesh on ``plane`` (n, c: n . p = c) hides nothing from ``frame``'s light:
    the light lies off the plane, on one side, and so does every box of ``boxes`` (lo, hi: the
    other surfaces that read the map). A ray from the light to a point on its side of the plane
    never crosses it, and a flat mesh cannot shadow itself. Points on the plane count as on the
    light's side (a sphere resting on a floor), within a hundred-thousandth of ``own_box``'s
    size; a light in the plane's own direction (grazing it) does not."""
    n, c = np.asarray(plane[0], np.float64), float(plane[1])
    lo, hi = (np.asarray(b, np.float64) for b in own_box)
    tol = 1e-5 * max(float(np.max(hi - lo)), 1e-30)
    if frame.kind == SHADOW_ORTHO:
        towards = -np.asarray(frame.matrix[2, :3], np.float64)  # depth grows away from the light
        side = float(n @ towards) / max(float(np.linalg.norm(towards)), 1e-30)
        if abs(side) <= 1e-6:
            return False
    else:
        side = float(n @ frame.origin) - c
        if abs(side) <= tol:
            return False
    sign = 1.0 if side > 0.0 else -1.0
    for box in boxes:
        if float((sign * (Bounds(*box).corners() @ n - c)).min()) < -tol:
            return False
    return True


def _release_arrays(value) -> None:
    """Release a (vertex array, buffers...) tuple, the vertex array first."""
    for obj in value:
        obj.release()
