"""Render passes, one module per ``shaders/passes`` entry point: G-buffer fill (:mod:`.gbuffer`),
lighting (:mod:`.shade`), transparent surfaces after lighting (:mod:`.forward`), tone mapping
(:mod:`.tonemap`).

Also SSAO (:mod:`.ssao`), the neural shadow estimator (:mod:`.shadow_net`), shadow maps (:mod:`.shadow`, :mod:`.shadow_bindings`), splats
(:mod:`.splats`), accumulation (:mod:`.accumulate`), antialiasing (:mod:`.antialias`), debug views
(:mod:`.debug_view`) and the bounded GPU uploads they draw from (:mod:`.uploads`,
:mod:`.mesh_uploads`, :mod:`.splat_resources`). A pass never allocates its targets: the frame
graph (:mod:`viewer.graph`) hands them over.

Imports: :mod:`viewer.errors`, :mod:`viewer.cache`, :mod:`viewer.gl`, :mod:`viewer.gbuffer`,
:mod:`viewer.models`, :mod:`viewer.scene`, :mod:`viewer.lighting`, :mod:`viewer.geometry`,
:mod:`viewer.splats`, :mod:`viewer.neural`; never the graph or the renderer.
"""
import numpy as np

from ..cache import BoundedCache
from ..gl.programs import on_release


def set_uniform(prog, name: str, value) -> None:
    """Set uniform ``name`` if ``prog`` has it (the compiler drops unused ones); ``bytes`` are
    written raw (matrices, arrays), anything else through ``.value``."""
    if name not in prog:
        return
    if isinstance(value, (bytes, bytearray)):
        prog[name].write(value)
    else:
        prog[name].value = value


def set_deferred_camera(prog, camera) -> None:
    """The camera uniforms of ``passes/deferred.glsl``: its frame, field of view and the frame's
    full resolution (what turns a pixel and its depth into a view ray and a position)."""
    basis = camera.basis()  # rows: right, up, back
    set_uniform(prog, "u_camera_to_world",
                np.ascontiguousarray(basis.astype(np.float32)).tobytes())
    set_uniform(prog, "u_tan_half_fov", camera.tan_half_fov())
    set_uniform(prog, "u_resolution", (float(camera.width), float(camera.height)))


def bind_gbuffer(prog, textures: dict, first_unit: int = 0) -> int:
    """Bind G-buffer attachment textures to the ``u_gbuffer<i>`` samplers ``prog`` uses (the
    generated ``gbuffer_load``); returns the next free texture unit."""
    unit = first_unit
    for index, tex in textures.items():
        name = f"u_gbuffer{index}"
        if name in prog:
            tex.use(unit)
            prog[name].value = unit
            unit += 1
    return unit


class FullscreenDraw:
    """Draws the single fullscreen triangle of ``passes/fullscreen.vert`` with any program,
    keeping one empty vertex array per program (no per-frame allocation). At most
    :data:`MAX_VAOS` programs' arrays are kept (least recently used released), and a program's
    array is released with the program (:func:`viewer.gl.programs.on_release`)."""

    MAX_VAOS = 16

    def __init__(self, ctx):
        self.ctx = ctx
        # id(program) -> (program, vertex array): the program is held, so its id is not reused
        # while the entry lives
        self._vaos = BoundedCache("fullscreen vertex arrays", max_items=self.MAX_VAOS,
                                  release=lambda entry: entry[1].release())

    def vao(self, program):
        """The empty vertex array of ``program`` (made on first use): instanced splat quads draw
        with it too."""
        entry = self._vaos.get(id(program))
        if entry is None or entry[0] is not program:
            entry = (program, self.ctx.vertex_array(program, []))
            self._vaos.put(id(program), entry)
            on_release(program, self._program_released)
        return entry[1]

    def __call__(self, program) -> None:
        vao = self.vao(program)
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND)
        vao.render(mode=self.ctx.TRIANGLES, vertices=3)

    def _program_released(self, program) -> None:
        entry = self._vaos.peek(id(program))
        if entry is not None and entry[0] is program:
            self._vaos.pop(id(program))

    def stats(self):
        return self._vaos.stats()

    def release(self) -> None:
        self._vaos.clear()
