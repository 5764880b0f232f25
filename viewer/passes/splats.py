"""The splat pass: Gaussian splats -> the same G-buffer as meshes, depth-tested against them.

Four steps per frame (``shaders/passes/splat_*``):

1. ``splat_project.comp`` - per splat: EWA projection (conic and quad axes), the baked SH colour
   along the view ray, the camera-facing normal, the depth key. Runs only when the view changes.
2. Sorting back to front, also only when the view changes: on the CPU
   (:func:`viewer.splats.sort.depth_order`, uploaded) or on the GPU (``splat_sort.comp``, a
   bitonic sort of (depth, index) pairs). Both give the same order.
3. ``splat_raster.vert/.frag`` - one instanced quad per splat into four RGBA32F accumulation
   targets with blending (ONE, ONE_MINUS_SRC_ALPHA); the G-buffer's depth texture (meshes) is
   attached read-only, so splats behind meshes are rejected.
4. ``splat_resolve.frag`` - normalises by coverage and composites over the G-buffer's previous
   content (a copy), writing through ``gbuffer_store``.

Depth (``[render] splat_depth``): ``"expected"`` is eq. 6.10, the blending-weighted mean of the
splat depths (one more channel of step 3). ``"median"`` is the depth where the accumulated opacity
reaches half the pixel's coverage (lib/splat.glsl): between steps 3 and 4, ``splat_median.frag``
redraws the splats 2 + :data:`MEDIAN_LEVELS` times (the depth range, one pass per search level,
the final pick) and ``splat_median_update.frag`` narrows the per-pixel range after each level,
so the median costs about five splat rasterisations more than the expected depth.

The torch twin is :func:`learned.splats.rasterize.rasterize`; ``relight parity --model splats``
compares the two.

Resources (:mod:`.splat_resources`): each cloud's buffers are cached by the cloud's identity
(released when it dies or its geometry cache entry is evicted), the concatenation of a scene's
clouds likewise (by the identities of its parts), and the accumulation targets per G-buffer shape,
at most :data:`MAX_ACCUM` shapes. Programs are looked up at every use (they may be evicted).
"""
from __future__ import annotations

import dataclasses

from ..cache import BoundedCache, CacheStats, array_bytes
from ..gbuffer import GBufferLayout
from ..scene.camera import Camera, gl_bytes
from ..scene.settings import SPLAT_DEPTHS
from ..splats.data import Splats, concat
from ..splats.sort import depth_order
from . import FullscreenDraw
from . import set_uniform as _set
from .splat_resources import RECORD, SplatAccum, SplatCopy, accum_key, upload_splats
from .uploads import UploadCache

__all__ = ["CHUNK", "DEPTHS", "MAX_ACCUM", "MEDIAN_LEVELS", "RECORD", "SORTS", "SplatPass",
           "camera_constants"]

CHUNK = 1 << 18  # splats per projection dispatch (keeps each bound range under SSBO limits)
SORTS = ("cpu", "gpu")
DEPTHS = SPLAT_DEPTHS  # [render] splat_depth
MEDIAN_LEVELS = 3  # search levels: the range shrinks 17x per level, then the nearest splat in it
MAX_ACCUM = 2  # G-buffer shapes whose accumulation targets are kept
_FAR = 3.0e38  # clear value of the min-blended targets ("no splat")
_RECORD_DEFINE = {"SPLAT_RECORD": f"{RECORD}u"}


def camera_constants(camera: Camera) -> dict:
    """Uniform values shared with the torch twin: focal lengths in pixels and tan(fov / 2)."""
    tx, ty = camera.tan_half_fov()
    return {"focal_tan": (camera.width / (2.0 * tx), camera.height / (2.0 * ty), tx, ty)}


class SplatPass:
    """Draws one splat cloud into a :class:`~viewer.passes.gbuffer.GBufferTargets`."""
    sort = "cpu"  # default for draw_clouds: "cpu" | "gpu" (relight.bench.splats measures both)

    def __init__(self, programs, layout: GBufferLayout):
        if not layout.with_color:
            raise ValueError("the splat pass needs a layout with the colour channel")
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self.uploads = UploadCache(self.ctx, "splat uploads", release=SplatCopy.release)
        # the concatenation of a scene's clouds (by the parts' identities); its buffers are in
        # ``uploads``, counted towards the parts' geometry entries and released with it
        self.clouds = UploadCache(self.ctx, "splat scenes", release=self.forget, max_items=2)
        # accum_key(targets) -> SplatAccum
        self.accum = BoundedCache("splat accumulation", max_items=MAX_ACCUM,
                                  release=SplatAccum.release)
        self._fullscreen = FullscreenDraw(self.ctx)
        # compile now: a broken shader fails when the pass is made, not in a frame
        self.programs.compute("passes/splat_project.comp", defines=_RECORD_DEFINE)
        self.programs.compute("passes/splat_sort.comp")
        self._raster()
        for d in DEPTHS:
            self._resolve(d)

    # ---- programs (looked up at every use: the cache may evict them) --------------------------
    def _raster(self, median_pass: int | None = None):
        if median_pass is None:
            return self.programs.graphics("passes/splat_raster.vert", "passes/splat_raster.frag",
                                          defines=_RECORD_DEFINE)
        return self.programs.graphics("passes/splat_raster.vert", "passes/splat_median.frag",
                                      defines={**_RECORD_DEFINE, "SPLAT_MEDIAN_PASS": median_pass})

    def _resolve(self, depth: str):
        return self.programs.graphics("passes/fullscreen.vert", "passes/splat_resolve.frag",
                                      defines={"SPLAT_DEPTH_MEDIAN": int(depth == "median")},
                                      virtual=self.layout.virtual_files())

    def _median_update(self, init: bool):
        return self.programs.graphics("passes/fullscreen.vert", "passes/splat_median_update.frag",
                                      defines={"SPLAT_MEDIAN_INIT": int(init)},
                                      virtual=self.layout.virtual_files())

    # ---- resources ---------------------------------------------------------------------------
    def upload(self, splats: Splats) -> SplatCopy:
        """The buffers of ``splats`` (uploaded on first use)."""
        return self.uploads.get_or_create(splats, None, lambda: self._upload(splats))

    def _upload(self, splats: Splats) -> tuple[SplatCopy, int]:
        copy = upload_splats(self.ctx, splats)
        return copy, copy.nbytes

    def _accum_targets(self, targets) -> SplatAccum:
        key = accum_key(targets)
        acc = self.accum.get(key)
        if acc is None:
            acc = SplatAccum.create(self.ctx, targets)
            self.accum.put(key, acc, acc.nbytes)
        return acc.attach(targets)

    # ---- the passes ------------------------------------------------------------------------------
    def prepare(self, splats: Splats, camera: Camera, sort: str = "cpu") -> SplatCopy:
        """Project and sort for ``camera`` (skipped when neither the view nor ``sort`` changed)."""
        if sort not in SORTS:
            raise ValueError(f"sort must be one of {SORTS}")
        entry = self.upload(splats)
        view, proj = camera.view_matrix(), camera.projection_matrix()
        key = gl_bytes(view) + gl_bytes(proj) + bytes(str(camera.size), "ascii")
        if entry.view_key == key and entry.sort == sort:
            return entry
        if entry.count:
            self._run_project(entry, camera, view, proj)
            if sort == "gpu":
                self._run_gpu_sort(entry)
            else:
                entry.cpu_order.write(depth_order(splats.means, view).tobytes())
        entry.view_key, entry.sort = key, sort
        return entry

    def _run_project(self, entry: SplatCopy, camera: Camera, view, proj) -> None:
        prog = self.programs.compute("passes/splat_project.comp", defines=_RECORD_DEFINE)
        prog["u_view"].write(gl_bytes(view))
        prog["u_projection"].write(gl_bytes(proj))
        _set(prog, "u_camera_ws", tuple(float(x) for x in camera.position))
        _set(prog, "u_focal_tan", camera_constants(camera)["focal_tan"])
        _set(prog, "u_resolution", (float(camera.width), float(camera.height)))
        _set(prog, "u_near_far", (float(camera.near), float(camera.far)))
        _set(prog, "u_sh_count", entry.sh_count)
        entry.projected.bind_to_storage_buffer(3)
        entry.keys.bind_to_storage_buffer(4)
        entry.order.bind_to_storage_buffer(5)
        k3 = entry.sh_count * 3
        for first in range(0, entry.count, CHUNK):
            count = min(CHUNK, entry.count - first)
            entry.geometry.bind_to_storage_buffer(0, offset=first * 48, size=count * 48)
            entry.material.bind_to_storage_buffer(1, offset=first * 32, size=count * 32)
            entry.sh.bind_to_storage_buffer(2, offset=first * k3 * 4, size=count * k3 * 4)
            _set(prog, "u_first", first)
            _set(prog, "u_count", count)
            prog.run((count + 127) // 128)
        self.ctx.memory_barrier()

    def _run_gpu_sort(self, entry: SplatCopy) -> None:
        prog = self.programs.compute("passes/splat_sort.comp")
        entry.keys.bind_to_storage_buffer(0)
        entry.order.bind_to_storage_buffer(1)
        n = entry.padded
        _set(prog, "u_count", n)
        groups = (n + 255) // 256
        k = 2
        while k <= n:
            j = k >> 1
            while j > 0:
                _set(prog, "u_k", k)
                _set(prog, "u_j", j)
                prog.run(groups)
                self.ctx.memory_barrier()
                j >>= 1
            k <<= 1

    def draw(self, targets, camera: Camera, splats: Splats, sort: str = "cpu",
             depth: str = "expected") -> None:
        """Composite ``splats`` into ``targets`` (after meshes and image stacks were drawn there).
        The camera is used at the targets' size; ``depth``: one of :data:`DEPTHS`."""
        if depth not in DEPTHS:
            raise ValueError(f"depth must be one of {DEPTHS}")
        ctx = self.ctx
        camera = camera.with_size(*targets.size)
        entry = self.prepare(splats, camera, sort)
        acc = self._accum_targets(targets)
        acc.clear.clear(0.0, 0.0, 0.0, 0.0)
        if entry.count:
            fbo = acc.fbo
            fbo.use()
            fbo.depth_mask = False
            ctx.viewport = (0, 0, *targets.size)
            ctx.enable(ctx.DEPTH_TEST | ctx.BLEND)
            ctx.depth_func = "<"
            ctx.blend_func = (ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA)
            ctx.blend_equation = ctx.FUNC_ADD
            try:
                entry.projected.bind_to_storage_buffer(0)
                (entry.order if entry.sort == "gpu" else entry.cpu_order).bind_to_storage_buffer(1)
                raster = self._raster()
                _set(raster, "u_resolution", (float(camera.width), float(camera.height)))
                self._fullscreen.vao(raster).render(ctx.TRIANGLE_STRIP, vertices=4,
                                                    instances=entry.count)
            finally:
                ctx.disable(ctx.DEPTH_TEST | ctx.BLEND)
                ctx.blend_func = ctx.DEFAULT_BLENDING
                fbo.depth_mask = True
        ctx.copy_framebuffer(acc.scratch_fbo, targets.fbo)
        if depth == "median":
            self._run_median(entry, acc, camera)
            self.accum.set_nbytes(accum_key(targets), acc.nbytes)  # + the search targets
        prog = self._resolve(depth)
        unit = 0
        for a, tex in acc.scratch.items():
            tex.use(unit)
            _set(prog, f"u_gbuffer{a}", unit)
            unit += 1
        for i, tex in enumerate(acc.textures):
            tex.use(unit)
            _set(prog, f"u_accum{i}", unit)
            unit += 1
        if depth == "median":
            acc.median["answer"].use(unit)
            _set(prog, "u_median", unit)
        targets.fbo.use()
        ctx.viewport = (0, 0, *targets.size)
        self._fullscreen(prog)

    # ---- median depth ----------------------------------------------------------------------------
    def _run_median(self, entry: SplatCopy, acc: SplatAccum, camera: Camera) -> None:
        """The median-depth search (module docstring): leaves the answer in
        ``acc.median["answer"]`` (r; 3e38 where no splat contributes)."""
        ctx = self.ctx
        m = acc.median_targets()
        size = acc.size
        m["range_fbo"].clear(_FAR, _FAR, _FAR, 0.0)
        m["answer_fbo"].clear(_FAR, _FAR, _FAR, _FAR)
        order = entry.order if entry.sort == "gpu" else entry.cpu_order

        def splats(i, fbo, state=None):
            if not entry.count:
                return
            prog = self._raster(median_pass=i)
            fbo.use()
            fbo.depth_mask = False
            ctx.viewport = (0, 0, *size)
            ctx.enable(ctx.DEPTH_TEST | ctx.BLEND)
            ctx.depth_func = "<"
            try:
                entry.projected.bind_to_storage_buffer(0)
                order.bind_to_storage_buffer(1)
                _set(prog, "u_resolution", (float(camera.width), float(camera.height)))
                if state is not None:
                    state.use(0)
                    _set(prog, "u_state", 0)
                self._fullscreen.vao(prog).render(ctx.TRIANGLE_STRIP, vertices=4,
                                                  instances=entry.count)
            finally:
                ctx.disable(ctx.DEPTH_TEST | ctx.BLEND)
                ctx.blend_func = ctx.DEFAULT_BLENDING
                ctx.blend_equation = ctx.FUNC_ADD
                fbo.depth_mask = True

        def fullscreen(prog, fbo, textures):
            for unit, (name, tex) in enumerate(textures.items()):
                tex.use(unit)
                _set(prog, name, unit)
            fbo.use()
            ctx.viewport = (0, 0, *size)
            self._fullscreen(prog)

        ctx.blend_equation = (ctx.MIN, ctx.MAX)
        splats(0, m["range_fbo"])
        under = {f"u_gbuffer{a}": t for a, t in acc.scratch.items()}
        fullscreen(self._median_update(init=True), m["state_fbo"][0],
                   {**under, "u_range": m["range"], "u_accum0": acc.textures[0]})
        cur = 0
        for _ in range(MEDIAN_LEVELS):
            m["search_fbo"].clear(1.0, 1.0, 1.0, 1.0)
            ctx.blend_func = (ctx.ZERO, ctx.SRC_COLOR)  # dst *= 1 - alpha: transmittance
            splats(1, m["search_fbo"], m["state"][cur])
            fullscreen(self._median_update(init=False), m["state_fbo"][1 - cur],
                       {"u_state": m["state"][cur], **{f"u_t{i}": t for i, t in enumerate(m["t"])}})
            cur = 1 - cur
        ctx.blend_equation = ctx.MIN
        splats(2, m["answer_fbo"], m["state"][cur])

    def draw_clouds(self, targets, camera: Camera, clouds: list[Splats],
                    depth: str = "expected") -> None:
        """:meth:`draw` for several clouds of one scene, concatenated (once) so they sort
        together."""
        parts = tuple(clouds)
        if len(parts) == 1:
            cloud = parts[0]
        else:
            def join():
                cat = concat(list(parts))
                return cat, array_bytes(*(getattr(cat, f.name) for f in dataclasses.fields(cat)))
            cloud = self.clouds.get_or_create(parts, None, join)
            # its buffers count towards (and are released with) the parts' geometry entries
            self.uploads.get_or_create(cloud, None, lambda: self._upload(cloud), account=parts)
        self.draw(targets, camera, cloud, sort=self.sort, depth=depth)

    def forget(self, splats: Splats) -> None:
        """Release the buffers of ``splats`` now (they are otherwise released when it dies)."""
        self.uploads.forget(splats)

    _forget = forget  # the name relight.bench.splats uses

    def stats(self) -> dict[str, CacheStats]:
        """Each cache of this pass (``Renderer.memory`` gathers them)."""
        return {"splat uploads": self.uploads.stats(), "splat scenes": self.clouds.stats(),
                "splat accumulation": self.accum.stats(),
                "splat vertex arrays": self._fullscreen.stats()}

    def release(self) -> None:
        self.clouds.release()
        self.uploads.release()
        self.accum.clear()
        self._fullscreen.release()
