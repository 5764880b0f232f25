"""Render passes, one module per ``shaders/passes`` entry point: G-buffer fill (:mod:`.gbuffer`),
lighting (:mod:`.shade`), transparent surfaces after lighting (:mod:`.forward`), tone mapping
(:mod:`.tonemap`)."""


def set_uniform(prog, name: str, value) -> None:
    """Set uniform ``name`` if ``prog`` has it (the compiler drops unused ones); ``bytes`` are
    written raw (matrices, arrays), anything else through ``.value``."""
    if name not in prog:
        return
    if isinstance(value, (bytes, bytearray)):
        prog[name].write(value)
    else:
        prog[name].value = value


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
    keeping one empty vertex array per program (no per-frame allocation)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._vaos: dict[int, object] = {}

    def __call__(self, program) -> None:
        vao = self._vaos.get(id(program))
        if vao is None:
            vao = self._vaos[id(program)] = self.ctx.vertex_array(program, [])
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND)
        vao.render(mode=self.ctx.TRIANGLES, vertices=3)

    def release(self) -> None:
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
