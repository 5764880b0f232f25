"""Resource descriptors of the frame graph: what a pass declares it writes (size, format,
channels), hashable so the target pool can key and reuse targets by them."""
from __future__ import annotations

from dataclasses import dataclass

from ..gbuffer import GBufferLayout
from ..passes.gbuffer import GBufferTargets

_DTYPE_BYTES = {"f1": 1, "f2": 2, "f4": 4, "u4": 4, "i4": 4}
_DTYPE_NAME = {"f1": "8", "f2": "16F", "f4": "32F", "u4": "32UI", "i4": "32I"}
_CHANNELS = {1: "R", 2: "RG", 3: "RGB", 4: "RGBA"}


@dataclass
class Target:
    """One colour texture (NEAREST filtered) and a framebuffer drawing to it."""

    texture: object
    fbo: object

    @property
    def size(self) -> tuple[int, int]:
        return tuple(self.texture.size)

    def release(self) -> None:
        self.fbo.release()
        self.texture.release()  # also self.depth


@dataclass(frozen=True)
class TextureDesc:
    """A 2D colour target: ``size`` (W, H), ``components`` 1-4, ``dtype`` ``f1`` (RGBA8), ``f2``,
    ``f4`` (float) or ``u4`` (unsigned integers)."""

    size: tuple[int, int]
    components: int = 4
    dtype: str = "f4"

    def create(self, ctx) -> Target:
        tex = ctx.texture(tuple(int(s) for s in self.size), self.components, dtype=self.dtype)
        tex.filter = (ctx.NEAREST, ctx.NEAREST)
        return Target(tex, ctx.framebuffer(color_attachments=[tex]))

    def bytes(self) -> int:
        return int(self.size[0]) * int(self.size[1]) * self.components * _DTYPE_BYTES[self.dtype]

    def describe(self) -> str:
        return (f"{self.size[0]}x{self.size[1]} {_CHANNELS[self.components]}"
                f"{_DTYPE_NAME[self.dtype]}")


@dataclass(frozen=True)
class MipTextureDesc(TextureDesc):
    """A :class:`TextureDesc` with its whole mip chain, trilinear filtered and clamped at the
    edges: an image a pass reads blurred at a level of its choice (the opaque frame's copy that
    transmissive surfaces refract, :mod:`viewer.passes.forward`). Its framebuffer draws level 0;
    the writer calls ``texture.build_mipmaps()`` after."""

    def create(self, ctx) -> Target:
        tex = ctx.texture(tuple(int(s) for s in self.size), self.components, dtype=self.dtype)
        tex.build_mipmaps()  # allocates the chain; trilinear (LINEAR_MIPMAP_LINEAR, LINEAR)
        tex.repeat_x = tex.repeat_y = False
        return Target(tex, ctx.framebuffer(color_attachments=[tex]))

    def bytes(self) -> int:
        return super().bytes() * 4 // 3  # the chain: 1 + 1/4 + 1/16 + ...

    def describe(self) -> str:
        return super().describe() + " + mips"


@dataclass(frozen=True)
class GBufferDesc:
    """The G-buffer of ``layout`` at ``size``: its attachments and a 24-bit depth buffer."""

    layout: GBufferLayout
    size: tuple[int, int]

    def create(self, ctx) -> GBufferTargets:
        return GBufferTargets.create(ctx, self.layout, self.size)

    def bytes(self) -> int:
        per = 4 * _DTYPE_BYTES[self.layout.dtype]
        return int(self.size[0]) * int(self.size[1]) * (per * len(self.layout.attachments) + 4)

    def describe(self) -> str:
        n = len(self.layout.attachments)
        return (f"{self.size[0]}x{self.size[1]} G-buffer {n} x RGBA{_DTYPE_NAME[self.layout.dtype]}"
                f" + depth")


@dataclass
class ShadowTarget:
    """A shadow map: one depth texture (24-bit normalised light depth, 1 where nothing is) that
    is both the depth test's buffer and what the lookups read (``texelFetch`` of a plain
    ``sampler2D``: no comparison mode), in a framebuffer with no colour attachment. Every shadow
    program's depth is the map's (``passes/shadow.frag``), so no colour copy is written: half the
    bytes a texel costs, and llvmpipe skips the colour stage of the draw.

    ``depth`` is ``texture`` (kept for code that releases both)."""

    texture: object
    depth: object
    fbo: object

    def release(self) -> None:
        self.fbo.release()
        self.texture.release()  # also self.depth


@dataclass(frozen=True)
class ShadowMapDesc:
    """A square shadow map of ``size`` texels a side, or (``faces=6``) a point light's cube map
    as an atlas of six such faces, 3 wide and 2 high (viewer/lighting/shadow_frames.py ShadowCube), or
    (``cascades`` 2..4) a directional light's cascades as an atlas of such tiles, 2 wide
    (viewer/lighting/cascades.py)."""

    size: int
    faces: int = 1
    cascades: int = 1

    @property
    def shape(self) -> tuple[int, int]:
        n = int(self.size)
        if self.cascades > 1:
            return (2 * n, n * ((self.cascades + 1) // 2))
        return (3 * n, 2 * n) if self.faces == 6 else (n, n)

    def create(self, ctx) -> ShadowTarget:
        shape = self.shape
        tex = ctx.depth_texture(shape)
        tex.compare_func = ""
        tex.filter = (ctx.NEAREST, ctx.NEAREST)
        tex.repeat_x = tex.repeat_y = False
        return ShadowTarget(tex, tex, ctx.framebuffer(depth_attachment=tex))

    def bytes(self) -> int:
        w, h = self.shape
        return w * h * 4

    def describe(self) -> str:
        if self.faces == 6:
            return f"6 x {self.size}x{self.size} cube shadow map, 24-bit depth"
        if self.cascades > 1:
            return f"{self.cascades} x {self.size}x{self.size} cascaded shadow map, 24-bit depth"
        return f"{self.size}x{self.size} shadow map, 24-bit depth"
