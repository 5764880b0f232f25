"""The G-buffer fill pass: triangle meshes and image-space stacks -> the layout's render targets.

:class:`GBufferTargets` owns one RGBA texture per layout attachment plus a depth texture;
:class:`GBufferPass` draws meshes (``passes/gbuffer_mesh.vert`` + ``.frag``, one program variant per
combination of texture maps) and image stacks (``passes/fullscreen.vert`` + ``gbuffer_image.frag``)
into them. Both write through ``gbuffer_store`` of the generated ``generated/gbuffer.glsl``.

Mesh pass variants (prepended defines): ``USE_BASE_COLOR_MAP``, ``USE_METALLIC_ROUGHNESS_MAP``,
``USE_NORMAL_MAP``, ``USE_OCCLUSION_MAP``, ``USE_EMISSIVE_MAP``; ``USE_UV0`` / ``USE_UV1`` when a
map reads that texture coordinate set; ``HAS_TANGENTS`` when a normal-mapped mesh has vertex
tangents (otherwise a cotangent frame from screen derivatives); ``USE_VERTEX_COLOR`` (COLOR_0);
``ALPHA_MASK`` (alpha mode MASK). Single-sided meshes are drawn with back-face culling.

Mesh uploads (buffers, vertex arrays, texture maps, samplers) live in :mod:`.mesh_uploads`; image
stacks are uploaded once per stack (:class:`~viewer.passes.uploads.UploadCache`, released with the
geometry cache entry holding the stack).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..cache import CacheStats, texture_bytes
from ..errors import InputError
from ..gbuffer import CHANNELS, GBufferLayout
from ..geometry.imagespace import ImageGBuffer
from ..geometry.mesh import Mesh
from ..geometry.proxy_snap import snapped
from ..scene.camera import Camera, gl_bytes
from . import FullscreenDraw
from . import set_uniform as _set
from .mesh_uploads import ANISOTROPY, MeshDraw, MeshUploads, mesh_defines
from .uploads import UploadCache

MAX_SNAPPED_STACKS = 4  # proxy-snapped copies of stacks kept (each: its depth channel again)

__all__ = ["ANISOTROPY", "GBufferPass", "GBufferTargets", "MeshDraw", "MeshUploads",
           "mesh_defines"]


@dataclass
class GBufferTargets:
    """Render targets for one G-buffer: attachment index -> RGBA texture, plus depth."""

    ctx: object
    layout: GBufferLayout
    size: tuple[int, int]  # (W, H)
    textures: dict[int, object]  # attachment index -> moderngl.Texture (layout.dtype, NEAREST)
    depth: object  # moderngl depth texture (24-bit: moderngl cannot allocate DEPTH32F)
    fbo: object
    _clear_fbos: dict[int, object] = field(default_factory=dict)
    _clear_values: dict[int, tuple[float, ...]] = field(default_factory=dict)

    @classmethod
    def create(cls, ctx, layout: GBufferLayout, size: tuple[int, int]) -> "GBufferTargets":
        w, h = int(size[0]), int(size[1])
        attachments = layout.attachments
        if attachments != tuple(range(len(attachments))):
            raise ValueError(f"layout attachments {attachments} are not 0..n-1")
        textures = {}
        for a in attachments:
            tex = ctx.texture((w, h), 4, dtype=layout.dtype)
            tex.filter = (ctx.NEAREST, ctx.NEAREST)
            tex.repeat_x = tex.repeat_y = False
            textures[a] = tex
        depth = ctx.depth_texture((w, h))
        fbo = ctx.framebuffer(color_attachments=[textures[a] for a in attachments],
                              depth_attachment=depth)
        packed = layout.pack(layout.background(1, 1))
        targets = cls(ctx=ctx, layout=layout, size=(w, h), textures=textures, depth=depth, fbo=fbo)
        for a in attachments:
            targets._clear_fbos[a] = ctx.framebuffer(color_attachments=[textures[a]])
            targets._clear_values[a] = tuple(float(v) for v in packed[a][0, 0])
        return targets

    def clear(self) -> None:
        """Depth to 1 and every attachment to the layout's packed background values."""
        self.fbo.clear(depth=1.0)
        for a, fbo in self._clear_fbos.items():
            fbo.clear(*self._clear_values[a])

    def read(self, names=None) -> dict[str, np.ndarray]:
        """Channel name -> ``[H, W, C]`` float32, row 0 at the top (default: every channel)."""
        channels = self.layout.channels
        w, h = self.size
        # channels the layout omits read back as their background value, as gbuffer_load does
        # (so does emission where the scene has none; a mesh's colour is made by the renderer)
        allocated = {c.name for c in channels}
        omitted = {c.name: c for c in CHANNELS if c.name not in allocated and c.name != "color"}
        if names is not None:
            wanted = set(names)
            unknown = wanted - {c.name for c in channels} - set(omitted)
            if unknown:
                raise KeyError(f"not in this G-buffer layout: {', '.join(sorted(unknown))}")
            channels = tuple(c for c in channels if c.name in wanted)
            omitted = {k: c for k, c in omitted.items() if k in wanted}
        fill = {k: np.broadcast_to(np.asarray(c.background, np.float32), (h, w, c.components)).copy()
                for k, c in omitted.items()}
        raw = {}
        np_dtype = np.float16 if self.layout.dtype == "f2" else np.float32
        for a in sorted({c.attachment for c in channels}):
            data = self.textures[a].read()
            raw[a] = np.frombuffer(data, np_dtype).reshape(h, w, 4)[::-1].astype(np.float32)
        out = {c.name: raw[c.attachment][:, :, c.offset:c.offset + c.components].copy()
               for c in channels}
        out.update(fill)
        return out

    def viewing(self, textures: dict[int, object]) -> "GBufferTargets":
        """The same G-buffer read from other textures of this layout and size (a lone image
        stack shaded in place); ``read`` works on it, drawing and ``release`` do not."""
        view = GBufferTargets(ctx=self.ctx, layout=self.layout, size=self.size,
                              textures=dict(textures), depth=None, fbo=None)
        return view

    def release(self) -> None:
        if self.fbo is None:  # a view (see viewing): owns nothing
            return
        for fbo in self._clear_fbos.values():
            fbo.release()
        self._clear_fbos.clear()
        self.fbo.release()
        for tex in self.textures.values():
            tex.release()
        self.depth.release()


class GBufferPass:
    """Fills a :class:`GBufferTargets` from meshes and image-space stacks."""

    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self.uploads = MeshUploads(self.ctx, self._program)
        self._draw = FullscreenDraw(self.ctx)  # the stacks' fullscreen triangle
        # stack -> [(attachment, texture)]: uploaded once per stack
        self.stacks = UploadCache(self.ctx, "stack uploads",
                                  release=lambda textures: [t.release() for _, t in textures])
        # stacks with their depth snapped to their proxies' (CPU copies; at most a few)
        self.snaps = UploadCache(self.ctx, "proxy-snapped stacks", release=lambda stack: None,
                                 max_items=MAX_SNAPPED_STACKS)

    # ---- meshes ----------------------------------------------------------------------------------
    def mesh_defines(self, mesh: Mesh) -> dict[str, int]:
        """The program variant for ``mesh`` (:func:`mesh_defines`)."""
        return mesh_defines(mesh)

    def _program(self, defines: dict[str, int], variant=None):
        return self.programs.graphics("passes/gbuffer_mesh.vert", "passes/gbuffer_mesh.frag",
                                      defines=defines, virtual=self.layout.virtual_files())

    def draw_meshes(self, targets: GBufferTargets, camera: Camera, meshes: list[Mesh]) -> None:
        """Rasterise ``meshes`` into ``targets``, depth-tested (call ``targets.clear()`` first).

        Every mesh given is drawn as a surface of the G-buffer, alphaMode BLEND ones too (the
        renderer routes those to the forward pass, :mod:`viewer.passes.forward`, instead).
        The camera is used at the targets' size; its own ``size`` is ignored. Each mesh is
        uploaded on first use and cached by identity: after editing a mesh's arrays in place,
        :meth:`release` (or draw a new :class:`Mesh`).
        """
        camera = camera.with_size(*targets.size)
        ctx = self.ctx
        targets.fbo.use()
        ctx.viewport = (0, 0, *targets.size)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE | ctx.BLEND)
        ctx.front_face = "ccw"
        ctx.cull_face = "back"
        try:
            for mesh in meshes:
                entry = self.uploads.upload(mesh)
                prog = entry.vao.program
                self.uploads.set_camera(prog, camera)
                units = self.uploads.bind_material(prog, entry)
                if mesh.double_sided:
                    ctx.disable(ctx.CULL_FACE)
                else:
                    ctx.enable(ctx.CULL_FACE)
                entry.vao.render(ctx.TRIANGLES)
                self.uploads.unbind(entry, units)
        finally:
            ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)

    # ---- image stacks ----------------------------------------------------------------------------
    def draw_image(self, targets: GBufferTargets, image: ImageGBuffer,
                   camera: Camera | None = None) -> None:
        """Write the stack's foreground pixels into ``targets`` (same size required).

        ``gl_FragDepth`` comes from the stored depth through ``camera``'s projection (default:
        ``image.camera()``, the stack's own camera at the origin), so meshes drawn with the same
        camera depth-test correctly against the stack. Background pixels (alpha 0) are not written.
        """
        if tuple(image.size) != tuple(targets.size):
            raise InputError(f"image G-buffer is {image.size[0]}x{image.size[1]} but the render "
                             f"targets are {targets.size[0]}x{targets.size[1]}",
                             where=image.source)
        camera = (camera or image.camera()).with_size(*targets.size)
        ctx = self.ctx
        w, h = targets.size
        prog = self.programs.graphics("passes/fullscreen.vert", "passes/gbuffer_image.frag",
                                      virtual=self.layout.virtual_files())
        try:
            for unit, (a, tex) in enumerate(self.stack_textures(image)):
                tex.use(unit)
                _set(prog, f"u_gbuffer{a}", unit)
            _set(prog, "u_projection", gl_bytes(camera.projection_matrix()))
            vao = self._draw.vao(prog)
            targets.fbo.use()
            ctx.viewport = (0, 0, w, h)
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.BLEND)
            vao.render(ctx.TRIANGLES, vertices=3)
        finally:
            ctx.disable(ctx.DEPTH_TEST)

    def stack_textures(self, image: ImageGBuffer) -> list[tuple[int, object]]:
        """The stack packed into this layout's attachments, uploaded once per stack (released
        when the stack dies or its geometry cache entry is evicted)."""

        def upload():
            ctx = self.ctx
            w, h = image.size
            known = {c.name for c in self.layout.channels}
            packed = self.layout.pack({k: v for k, v in image.channels.items() if k in known})
            textures = []
            for a, arr in sorted(packed.items()):
                # GL row order (row 0 at the bottom): the same addressing as a G-buffer target,
                # so the lighting pass can read a lone stack's textures directly
                tex = ctx.texture((w, h), 4, np.ascontiguousarray(arr[::-1], np.float32).tobytes(),
                                  dtype="f4")
                tex.filter = (ctx.NEAREST, ctx.NEAREST)
                textures.append((a, tex))
            return textures, sum(texture_bytes(t) for _, t in textures)
        return self.stacks.get_or_create(image, None, upload)

    _stack_textures = stack_textures  # the name viewer.renderer used

    def snapped_stack(self, targets: GBufferTargets, image: ImageGBuffer, camera: Camera,
                      proxies: tuple[Mesh, ...], tolerance: float) -> ImageGBuffer:
        """``image`` with its depth snapped to the depth of ``proxies`` seen through ``camera``
        (:func:`viewer.geometry.proxy_snap.snapped`, within ``tolerance`` of it), made once per
        stack, proxies, camera and tolerance: the proxies are drawn into ``targets`` (which this
        clears; call it before drawing the frame's G-buffer) and their depth read back."""

        def make():
            targets.clear()
            self.draw_meshes(targets, camera, list(proxies))
            proxy = targets.read(("depth",))["depth"]
            targets.clear()
            out = snapped(image, proxy, tolerance)
            return out, int(out.channels["depth"].nbytes)
        return self.snaps.get_or_create((image, *proxies), (float(tolerance), camera), make)

    def stats(self) -> dict[str, CacheStats]:
        """Each upload cache of this pass (``Renderer.memory`` gathers them)."""
        return {**{f"gbuffer {k}": v for k, v in self.uploads.stats().items()},
                "gbuffer stacks": self.stacks.stats(), "gbuffer vertex arrays": self._draw.stats(),
                "gbuffer snapped stacks": self.snaps.stats()}

    def release(self) -> None:
        """Free every uploaded mesh and texture."""
        self.uploads.release()
        self.stacks.release()
        self.snaps.release()
        self._draw.release()
