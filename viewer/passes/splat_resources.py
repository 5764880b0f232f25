"""The GPU resources of the splat pass (:mod:`viewer.passes.splats`): each cloud's buffers (made
once per cloud, cached by its identity in an :class:`~viewer.passes.uploads.UploadCache`) and the
accumulation targets of one G-buffer shape (the four RGBA32F accumulation targets, a scratch copy
of the G-buffer and, for the median depth, the search targets)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..cache import texture_bytes
from ..splats.data import Splats

RECORD = 24  # floats per projected splat (see splat_project.comp)


@dataclass(eq=False)
class SplatCopy:
    """The buffers of one uploaded cloud, and the view its records and order were made for."""

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
    view_key: bytes | None = None  # the camera the records and order were made for
    sort: str | None = None

    def buffers(self) -> tuple:
        return (self.geometry, self.material, self.sh, self.projected, self.keys, self.order,
                self.cpu_order)

    @property
    def nbytes(self) -> int:
        return sum(b.size for b in self.buffers())

    def release(self) -> None:
        for b in self.buffers():
            b.release()


def upload_splats(ctx, splats: Splats) -> SplatCopy:
    """The storage buffers of ``splats`` (at least one record, so empty clouds bind too)."""
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
    return SplatCopy(
        count=n, padded=padded, sh_count=k,
        geometry=ctx.buffer(geo.tobytes()), material=ctx.buffer(mat.tobytes()),
        sh=ctx.buffer(sh.tobytes()), projected=ctx.buffer(reserve=m * RECORD * 4),
        keys=ctx.buffer(keys.tobytes()), order=ctx.buffer(order.tobytes()),
        cpu_order=ctx.buffer(reserve=m * 4))


def accum_key(targets) -> tuple:
    """What the accumulation targets depend on: the G-buffer's size and attachments' format."""
    return (tuple(targets.size), targets.layout.dtype, tuple(sorted(targets.textures)))


def _target(ctx, size, dtype="f4"):
    t = ctx.texture(tuple(size), 4, dtype=dtype)
    t.filter = (ctx.NEAREST, ctx.NEAREST)
    return t


@dataclass(eq=False)
class SplatAccum:
    """The accumulation targets for G-buffers of one shape (:func:`accum_key`). The framebuffers
    that attach a G-buffer's depth texture are made for one G-buffer at a time
    (:meth:`attach`)."""

    ctx: object
    size: tuple[int, int]
    textures: list  # 4 RGBA32F accumulation targets
    scratch: dict  # attachment -> a copy of the G-buffer's previous content
    clear: object  # framebuffer of ``textures`` (no depth)
    scratch_fbo: object
    median: dict | None = None  # the median-depth search targets (made on first use)
    depth: object = None  # the G-buffer depth texture the framebuffers below attach
    fbo: object = None  # ``textures`` + that depth (read-only)
    median_fbos: dict = field(default_factory=dict)

    @classmethod
    def create(cls, ctx, targets) -> "SplatAccum":
        tex = [_target(ctx, targets.size) for _ in range(4)]
        scratch = {a: _target(ctx, targets.size, targets.layout.dtype) for a in targets.textures}
        return cls(ctx=ctx, size=tuple(targets.size), textures=tex, scratch=scratch,
                   clear=ctx.framebuffer(color_attachments=tex),
                   scratch_fbo=ctx.framebuffer(color_attachments=[scratch[a]
                                                                  for a in sorted(scratch)]))

    def attach(self, targets) -> "SplatAccum":
        """Make the depth-tested framebuffers for ``targets``' depth texture (if not already)."""
        if self.depth is not targets.depth:
            self._release_depth_fbos()
            self.depth = targets.depth
            self.fbo = self.ctx.framebuffer(color_attachments=self.textures,
                                            depth_attachment=self.depth)
        return self

    def median_targets(self) -> dict:
        """The median search's targets (made once) and their framebuffers for the attached
        depth."""
        ctx = self.ctx
        if self.median is None:
            self.median = {"range": _target(ctx, self.size),
                           "state": [_target(ctx, self.size), _target(ctx, self.size)],
                           "t": [_target(ctx, self.size) for _ in range(4)],
                           "answer": _target(ctx, self.size)}
            self.median["state_fbo"] = [ctx.framebuffer([t]) for t in self.median["state"]]
        m = self.median
        if not self.median_fbos:
            self.median_fbos = {
                "range_fbo": ctx.framebuffer([m["range"]], depth_attachment=self.depth),
                "search_fbo": ctx.framebuffer(m["t"], depth_attachment=self.depth),
                "answer_fbo": ctx.framebuffer([m["answer"]], depth_attachment=self.depth)}
        return {**m, **self.median_fbos}

    @property
    def nbytes(self) -> int:
        textures = self.textures + list(self.scratch.values())
        if self.median is not None:
            m = self.median
            textures += [m["range"], m["answer"], *m["state"], *m["t"]]
        return sum(texture_bytes(t) for t in textures)

    def _release_depth_fbos(self) -> None:
        if self.fbo is not None:
            self.fbo.release()
        for f in self.median_fbos.values():
            f.release()
        self.fbo, self.median_fbos = None, {}

    def release(self) -> None:
        self._release_depth_fbos()
        for f in (self.clear, self.scratch_fbo):
            f.release()
        for t in self.textures + list(self.scratch.values()):
            t.release()
        if self.median is not None:
            m = self.median
            for f in m["state_fbo"]:
                f.release()
            for t in [m["range"], m["answer"], *m["state"], *m["t"]]:
                t.release()
            self.median = None
