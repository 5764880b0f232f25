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
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Camera, gl_bytes
from ..gbuffer import GBufferLayout
from ..settings import SPLAT_DEPTHS
from ..splats.data import Splats, concat
from ..splats.sort import depth_order
from . import FullscreenDraw
from . import set_uniform as _set

RECORD = 24  # floats per projected splat (see splat_project.comp)
CHUNK = 1 << 18  # splats per projection dispatch (keeps each bound range under SSBO limits)
SORTS = ("cpu", "gpu")
DEPTHS = SPLAT_DEPTHS  # [render] splat_depth
MEDIAN_LEVELS = 3  # search levels: the range shrinks 17x per level, then the nearest splat in it
_FAR = 3.0e38  # clear value of the min-blended targets ("no splat")


def camera_constants(camera: Camera) -> dict:
    """Uniform values shared with the torch twin: focal lengths in pixels and tan(fov / 2)."""
    tx, ty = camera.tan_half_fov()
    return {"focal_tan": (camera.width / (2.0 * tx), camera.height / (2.0 * ty), tx, ty)}


@dataclass
class _Uploaded:
    splats: Splats  # held so id() cannot be reused while the entry lives
    count: int
    padded: int  # power of two >= count, for the bitonic sort
    sh_count: int
    geometry: object
    material: object
    sh: object
    projected: object
    keys: object
    order: object  # GPU-sorted order (in place)
    cpu_order: object
    vao: object | None = None
    view_key: bytes | None = None  # the camera the records and order were made for
    sort: str | None = None


class SplatPass:
    """Draws one splat cloud into a :class:`~viewer.passes.gbuffer.GBufferTargets`."""
    sort = "cpu"  # default for draw_clouds: "cpu" | "gpu" (relight.bench.splats measures both)

    def __init__(self, programs, layout: GBufferLayout):
        if not layout.with_color:
            raise ValueError("the splat pass needs a layout with the colour channel")
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self._uploads: dict[int, _Uploaded] = {}
        self._accum: dict[int, dict] = {}  # id(targets) -> accumulation resources
        self._clouds: dict[tuple, tuple] = {}  # ids of the parts -> (parts, concatenation)
        self._fullscreen = FullscreenDraw(self.ctx)
        defines = {"SPLAT_RECORD": f"{RECORD}u"}
        self._project = programs.compute("passes/splat_project.comp", defines=defines)
        self._sort = programs.compute("passes/splat_sort.comp")
        self._raster = programs.graphics("passes/splat_raster.vert", "passes/splat_raster.frag",
                                         defines=defines)
        self._resolve = {
            mode: programs.graphics("passes/fullscreen.vert", "passes/splat_resolve.frag",
                                    defines={"SPLAT_DEPTH_MEDIAN": int(mode == "median")},
                                    virtual=layout.virtual_files()) for mode in DEPTHS}
        self._median = None  # the median-depth programs, built on first use

    # ---- resources ---------------------------------------------------------------------------
    def upload(self, splats: Splats) -> _Uploaded:
        entry = self._uploads.get(id(splats))
        if entry is not None and entry.splats is splats:
            return entry
        ctx = self.ctx
        n = len(splats)
        m = max(n, 1)
        geo = np.zeros((m, 12), np.float32)
        geo[:n, 0:3] = splats.means
        geo[:n, 3] = splats.opacities
        geo[:n, 4:8] = splats.rotations
        geo[:n, 8:11] = splats.scales
        mat = np.zeros((m, 8), np.float32)
        mat[:n, 0:3] = splats.albedo
        mat[:n, 3] = splats.roughness
        mat[:n, 4:7] = splats.normals
        mat[:n, 7] = splats.metallic
        k = splats.sh.shape[1]
        sh = np.zeros((m, k, 3), np.float32)
        sh[:n] = splats.sh
        padded = 1 << max(int(np.ceil(np.log2(m))), 0)
        keys = np.full(padded, -np.inf, np.float32)
        order = np.arange(padded, dtype=np.uint32)
        entry = _Uploaded(
            splats=splats, count=n, padded=padded, sh_count=k,
            geometry=ctx.buffer(geo.tobytes()), material=ctx.buffer(mat.tobytes()),
            sh=ctx.buffer(sh.tobytes()), projected=ctx.buffer(reserve=m * RECORD * 4),
            keys=ctx.buffer(keys.tobytes()), order=ctx.buffer(order.tobytes()),
            cpu_order=ctx.buffer(reserve=m * 4))
        entry.vao = ctx.vertex_array(self._raster, [])
        self._uploads[id(splats)] = entry
        return entry

    def _accum_targets(self, targets) -> dict:
        acc = self._accum.get(id(targets))
        if acc is not None and acc["targets"] is targets:
            return acc
        ctx = self.ctx
        tex = []
        for _ in range(4):
            t = ctx.texture(targets.size, 4, dtype="f4")
            t.filter = (ctx.NEAREST, ctx.NEAREST)
            tex.append(t)
        scratch = {}
        for a, t in targets.textures.items():
            s = ctx.texture(targets.size, 4, dtype=targets.layout.dtype)
            s.filter = (ctx.NEAREST, ctx.NEAREST)
            scratch[a] = s
        acc = {
            "targets": targets, "textures": tex,
            "fbo": ctx.framebuffer(color_attachments=tex, depth_attachment=targets.depth),
            "clear": ctx.framebuffer(color_attachments=tex),
            "scratch": scratch,
            "scratch_fbo": ctx.framebuffer(color_attachments=[scratch[a] for a in sorted(scratch)]),
        }
        self._accum[id(targets)] = acc
        return acc

    # ---- the passes ------------------------------------------------------------------------------
    def prepare(self, splats: Splats, camera: Camera, sort: str = "cpu") -> _Uploaded:
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

    def _run_project(self, entry: _Uploaded, camera: Camera, view, proj) -> None:
        prog = self._project
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

    def _run_gpu_sort(self, entry: _Uploaded) -> None:
        prog = self._sort
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
        acc["clear"].clear(0.0, 0.0, 0.0, 0.0)
        if entry.count:
            fbo = acc["fbo"]
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
                _set(self._raster, "u_resolution", (float(camera.width), float(camera.height)))
                entry.vao.render(ctx.TRIANGLE_STRIP, vertices=4, instances=entry.count)
            finally:
                ctx.disable(ctx.DEPTH_TEST | ctx.BLEND)
                ctx.blend_func = ctx.DEFAULT_BLENDING
                fbo.depth_mask = True
        ctx.copy_framebuffer(acc["scratch_fbo"], targets.fbo)
        if depth == "median":
            self._run_median(entry, acc, camera)
        prog = self._resolve[depth]
        unit = 0
        for a, tex in acc["scratch"].items():
            tex.use(unit)
            _set(prog, f"u_gbuffer{a}", unit)
            unit += 1
        for i, tex in enumerate(acc["textures"]):
            tex.use(unit)
            _set(prog, f"u_accum{i}", unit)
            unit += 1
        if depth == "median":
            acc["median"]["answer"].use(unit)
            _set(prog, "u_median", unit)
        targets.fbo.use()
        ctx.viewport = (0, 0, *targets.size)
        self._fullscreen(prog)

    # ---- median depth ----------------------------------------------------------------------------
    def _median_programs(self) -> dict:
        if self._median is None:
            p = self.programs
            raster = {i: p.graphics("passes/splat_raster.vert", "passes/splat_median.frag",
                                    defines={"SPLAT_RECORD": f"{RECORD}u", "SPLAT_MEDIAN_PASS": i})
                      for i in range(3)}
            self._median = {
                "raster": raster,
                "vaos": {i: self.ctx.vertex_array(prog, []) for i, prog in raster.items()},
                "init": p.graphics("passes/fullscreen.vert", "passes/splat_median_update.frag",
                                   defines={"SPLAT_MEDIAN_INIT": 1},
                                   virtual=self.layout.virtual_files()),
                "refine": p.graphics("passes/fullscreen.vert", "passes/splat_median_update.frag",
                                     defines={"SPLAT_MEDIAN_INIT": 0},
                                     virtual=self.layout.virtual_files()),
            }
        return self._median

    def _median_targets(self, acc: dict) -> dict:
        if "median" not in acc:
            ctx, targets = self.ctx, acc["targets"]

            def tex():
                t = ctx.texture(targets.size, 4, dtype="f4")
                t.filter = (ctx.NEAREST, ctx.NEAREST)
                return t
            m = {"range": tex(), "state": [tex(), tex()], "t": [tex() for _ in range(4)],
                 "answer": tex()}
            m["range_fbo"] = ctx.framebuffer([m["range"]], depth_attachment=targets.depth)
            m["search_fbo"] = ctx.framebuffer(m["t"], depth_attachment=targets.depth)
            m["answer_fbo"] = ctx.framebuffer([m["answer"]], depth_attachment=targets.depth)
            m["state_fbo"] = [ctx.framebuffer([t]) for t in m["state"]]
            acc["median"] = m
        return acc["median"]

    def _run_median(self, entry: _Uploaded, acc: dict, camera: Camera) -> None:
        """The median-depth search (module docstring): leaves the answer in
        ``acc["median"]["answer"]`` (r; 3e38 where no splat contributes)."""
        ctx = self.ctx
        progs = self._median_programs()
        m = self._median_targets(acc)
        size = acc["targets"].size
        m["range_fbo"].clear(_FAR, _FAR, _FAR, 0.0)
        m["answer_fbo"].clear(_FAR, _FAR, _FAR, _FAR)
        order = entry.order if entry.sort == "gpu" else entry.cpu_order

        def splats(i, fbo, state=None):
            if not entry.count:
                return
            prog = progs["raster"][i]
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
                progs["vaos"][i].render(ctx.TRIANGLE_STRIP, vertices=4, instances=entry.count)
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
        under = {f"u_gbuffer{a}": t for a, t in acc["scratch"].items()}
        fullscreen(progs["init"], m["state_fbo"][0],
                   {**under, "u_range": m["range"], "u_accum0": acc["textures"][0]})
        cur = 0
        for _ in range(MEDIAN_LEVELS):
            m["search_fbo"].clear(1.0, 1.0, 1.0, 1.0)
            ctx.blend_func = (ctx.ZERO, ctx.SRC_COLOR)  # dst *= 1 - alpha: transmittance
            splats(1, m["search_fbo"], m["state"][cur])
            fullscreen(progs["refine"], m["state_fbo"][1 - cur],
                       {"u_state": m["state"][cur], **{f"u_t{i}": t for i, t in enumerate(m["t"])}})
            cur = 1 - cur
        ctx.blend_equation = ctx.MIN
        splats(2, m["answer_fbo"], m["state"][cur])

    def draw_clouds(self, targets, camera: Camera, clouds: list[Splats],
                    depth: str = "expected") -> None:
        """:meth:`draw` for several clouds of one scene, concatenated (once) so they sort
        together."""

        key = tuple(id(c) for c in clouds)
        if key not in self._clouds:
            for old_parts, old in self._clouds.values():  # one scene at a time: free the last
                self._forget(old)
            self._clouds.clear()
            self._clouds[key] = (list(clouds), concat(list(clouds)))
        self.draw(targets, camera, self._clouds[key][1], sort=self.sort, depth=depth)

    def _forget(self, splats: Splats) -> None:
        e = self._uploads.pop(id(splats), None)
        if e is not None:
            for b in (e.geometry, e.material, e.sh, e.projected, e.keys, e.order, e.cpu_order):
                b.release()
            e.vao.release()

    def release(self) -> None:
        self._clouds.clear()
        for e in self._uploads.values():
            for b in (e.geometry, e.material, e.sh, e.projected, e.keys, e.order, e.cpu_order):
                b.release()
            if e.vao is not None:
                e.vao.release()
        self._uploads.clear()
        for acc in self._accum.values():
            for key in ("fbo", "clear", "scratch_fbo"):
                acc[key].release()
            for t in acc["textures"] + list(acc["scratch"].values()):
                t.release()
            m = acc.get("median")
            if m is not None:
                for f in [m["range_fbo"], m["search_fbo"], m["answer_fbo"], *m["state_fbo"]]:
                    f.release()
                for t in [m["range"], m["answer"], *m["state"], *m["t"]]:
                    t.release()
        self._accum.clear()
        if self._median is not None:
            for vao in self._median["vaos"].values():
                vao.release()
            self._median = None
        self._fullscreen.release()
