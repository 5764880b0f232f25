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

Texture maps: each image is uploaded once (RGBA16F, mipmapped); its glTF sampler becomes a
moderngl sampler object (REPEAT / CLAMP_TO_EDGE per axis, the filters, 8x anisotropy with
mipmapped linear filtering), MIRRORED_REPEAT is applied in the shader (moderngl has no such wrap
mode). Why anisotropy matters for speed on llvmpipe: its anisotropic filter's cost grows with the
footprint once that exceeds the coarsest mip level - a 128^2 sphere whose uvs span 0..4279 (the
quantised Duck's integer texture coordinates without their KHR_texture_transform) took 0.6 s per
draw against 0.014 s at uv 0..1 and 0.009 s without anisotropy. The time showed up in whatever GL
call next waited for the queued draw (the environment's mipmap building), not in the draw call.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..camera import Camera, gl_bytes
from ..errors import InputError
from ..gbuffer import CHANNELS, GBufferLayout
from ..geometry.imagespace import ImageGBuffer
from ..geometry.mesh import Mesh, TextureSampling
from . import set_uniform as _set

_MAP_DEFINES = {"base_color": "USE_BASE_COLOR_MAP",
                "metallic_roughness": "USE_METALLIC_ROUGHNESS_MAP",
                "normal": "USE_NORMAL_MAP", "occlusion": "USE_OCCLUSION_MAP",
                "emissive": "USE_EMISSIVE_MAP"}
_DEFAULT_SAMPLING = TextureSampling()
ANISOTROPY = 8.0  # for mipmapped linear filtering


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


@dataclass
class _Uploaded:
    mesh: Mesh  # held so id(mesh) cannot be reused while the entry lives
    vao: object
    buffers: list
    # map key -> (texture, sampler object, TextureSampling); textures and samplers are shared
    textures: dict[str, tuple]
    defines: dict[str, int]


def mesh_defines(mesh: Mesh) -> dict[str, int]:
    """The mesh program variant for ``mesh``: one define per texture map it has (and can use),
    the texture coordinate sets they read, vertex colours, the alpha mask."""
    defines = {}
    uv_sets = (mesh.uvs, mesh.uvs1)
    for key in mesh.textures:
        if key not in _MAP_DEFINES:
            continue
        texcoord = mesh.sampling.get(key, _DEFAULT_SAMPLING).texcoord
        if uv_sets[texcoord] is None:
            continue
        defines[_MAP_DEFINES[key]] = 1
        defines[f"USE_UV{texcoord}"] = 1
    if "USE_NORMAL_MAP" in defines and mesh.tangents is not None:
        defines["HAS_TANGENTS"] = 1
    if mesh.colors is not None:
        defines["USE_VERTEX_COLOR"] = 1
    if mesh.alpha_mode == "MASK":
        defines["ALPHA_MASK"] = 1
    return defines


class MeshUploads:
    """GPU copies of meshes for the programs of one pass (``program(defines, variant)``: the
    G-buffer fill, or the forward pass with its lighting variant): vertex buffers and a vertex
    array per mesh and variant, each image once (RGBA16F, mipmapped), one sampler object per
    distinct wrap/filter combination. Cached by mesh identity: after editing a mesh's arrays in
    place, :meth:`release` (or draw a new :class:`Mesh`)."""

    def __init__(self, ctx, program):
        self.ctx = ctx
        self._program = program  # (mesh defines, variant) -> program
        self._meshes: dict[tuple, _Uploaded] = {}  # (id(mesh), variant) -> upload
        self._textures: dict[int, tuple[np.ndarray, object]] = {}  # id(array) -> (array, texture)
        self._samplers: dict[tuple, object] = {}  # (wrap, mag, min filter) -> sampler object

    def _texture(self, image: np.ndarray):
        key = id(image)
        if key not in self._textures:
            arr = np.asarray(image, np.float32)
            if arr.ndim == 2:
                arr = arr[:, :, None]
            h, w, c = arr.shape
            rgba = np.zeros((h, w, 4), np.float16)
            rgba[:, :, 3] = 1.0
            rgba[:, :, :c] = arr[:, :, :4]
            if c == 1:  # grey: replicate so .rgb reads the value
                rgba[:, :, 1] = rgba[:, :, 2] = rgba[:, :, 0]
            # numpy row 0 (the image top) becomes texture row t = 0, which is where glTF uv v = 0
            # samples: no flip.
            tex = self.ctx.texture((w, h), 4, np.ascontiguousarray(rgba).tobytes(), dtype="f2")
            tex.build_mipmaps()
            self._textures[key] = (image, tex)
        return self._textures[key][1]

    def _sampler(self, sampling: TextureSampling):
        """A sampler object for ``sampling``'s wrap and filter modes (shared by equal ones)."""
        ctx = self.ctx
        key = (sampling.wrap, sampling.mag_filter, sampling.min_filter)
        if key not in self._samplers:
            min_filter = {"nearest": ctx.NEAREST, "linear": ctx.LINEAR,
                          "nearest_mipmap_nearest": ctx.NEAREST_MIPMAP_NEAREST,
                          "linear_mipmap_nearest": ctx.LINEAR_MIPMAP_NEAREST,
                          "nearest_mipmap_linear": ctx.NEAREST_MIPMAP_LINEAR,
                          "linear_mipmap_linear": ctx.LINEAR_MIPMAP_LINEAR}[sampling.min_filter]
            mag_filter = ctx.LINEAR if sampling.mag_filter == "linear" else ctx.NEAREST
            aniso = ANISOTROPY if sampling.min_filter.startswith("linear_mipmap") else 1.0
            self._samplers[key] = ctx.sampler(
                repeat_x=sampling.wrap[0] == "repeat", repeat_y=sampling.wrap[1] == "repeat",
                filter=(min_filter, mag_filter), anisotropy=aniso)
        return self._samplers[key]

    def upload(self, mesh: Mesh, variant=None) -> _Uploaded:
        """The mesh's vertex array (with its program for ``variant``, any hashable the program
        callback understands) and textures, uploaded on first use."""
        entry = self._meshes.get((id(mesh), variant))
        if entry is not None and entry.mesh is mesh:
            return entry
        mesh.validated()
        defines = mesh_defines(mesh)
        prog = self._program(defines, variant)
        arrays = {"in_position": (mesh.positions, "3f"), "in_normal": (mesh.normals, "3f")}
        if "USE_UV0" in defines:
            arrays["in_uv0"] = (mesh.uvs, "2f")
        if "USE_UV1" in defines:
            arrays["in_uv1"] = (mesh.uvs1, "2f")
        if "HAS_TANGENTS" in defines:
            arrays["in_tangent"] = (mesh.tangents, "4f")
        if "USE_VERTEX_COLOR" in defines:
            arrays["in_color"] = (mesh.colors, "4f")
        buffers, content = [], []
        for name, (arr, fmt) in arrays.items():
            buf = self.ctx.buffer(np.ascontiguousarray(arr, np.float32).tobytes())
            buffers.append(buf)
            if name in prog:  # the compiler may drop an unused attribute
                content.append((buf, fmt, name))
        ibo = self.ctx.buffer(np.ascontiguousarray(mesh.indices, np.uint32).tobytes())
        buffers.append(ibo)
        vao = self.ctx.vertex_array(prog, content, index_buffer=ibo, index_element_size=4)
        textures = {k: (self._texture(mesh.textures[k]),
                        self._sampler(mesh.sampling.get(k, _DEFAULT_SAMPLING)),
                        mesh.sampling.get(k, _DEFAULT_SAMPLING))
                    for k in mesh.textures if _MAP_DEFINES.get(k) in defines}
        entry = _Uploaded(mesh=mesh, vao=vao, buffers=buffers, textures=textures, defines=defines)
        self._meshes[(id(mesh), variant)] = entry
        return entry

    @staticmethod
    def set_camera(prog, camera: Camera) -> None:
        _set(prog, "u_view", gl_bytes(camera.view_matrix()))
        _set(prog, "u_projection", gl_bytes(camera.projection_matrix()))

    @staticmethod
    def bind_material(prog, entry: _Uploaded, first_unit: int = 0) -> list[int]:
        """Set the uniforms of ``mesh_surface.glsl`` for ``entry``'s mesh and bind its maps from
        texture unit ``first_unit`` on; returns the units used (for :meth:`unbind`)."""
        mesh = entry.mesh
        m = mesh.material
        _set(prog, "u_albedo", tuple(float(c) for c in m.albedo))
        _set(prog, "u_base_alpha", float(mesh.base_alpha))
        _set(prog, "u_roughness", float(m.roughness))
        _set(prog, "u_metallic", float(m.metallic))
        _set(prog, "u_specular", float(m.specular))
        _set(prog, "u_ao", float(m.ao))
        _set(prog, "u_normal_scale", float(mesh.normal_scale))
        _set(prog, "u_occlusion_strength", float(mesh.occlusion_strength))
        _set(prog, "u_emissive", tuple(float(c) for c in mesh.emissive))
        _set(prog, "u_alpha_cutoff", float(mesh.alpha_cutoff))
        units = []
        for unit, (key, (tex, sampler, sampling)) in enumerate(entry.textures.items(),
                                                                 start=first_unit):
            tex.use(unit)
            sampler.use(unit)
            _set(prog, f"u_{key}_map", unit)
            _set(prog, f"u_{key}_set", int(sampling.texcoord))
            _set(prog, f"u_{key}_uv",
                 np.ascontiguousarray(sampling.uv_matrix().T, np.float32).tobytes())
            _set(prog, f"u_{key}_mirror", tuple(float(w == "mirror") for w in sampling.wrap))
            units.append(unit)
        return units

    @staticmethod
    def unbind(entry: _Uploaded, units: list[int]) -> None:
        """Unbind the sampler objects :meth:`bind_material` bound (plain textures keep their own
        filtering again)."""
        for unit, (_, sampler, _) in zip(units, entry.textures.values()):
            sampler.clear(unit)

    def release(self) -> None:
        for entry in self._meshes.values():
            entry.vao.release()
            for buf in entry.buffers:
                buf.release()
        self._meshes.clear()
        for _, tex in self._textures.values():
            tex.release()
        self._textures.clear()
        for sampler in self._samplers.values():
            sampler.release()
        self._samplers.clear()


class GBufferPass:
    """Fills a :class:`GBufferTargets` from meshes and image-space stacks."""

    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self.uploads = MeshUploads(self.ctx, self._program)
        self._empty_vao = None
        self._stacks: dict[int, tuple[object, list]] = {}  # id(image) -> (image, textures)

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
            for unit, (a, tex) in enumerate(self._stack_textures(image)):
                tex.use(unit)
                _set(prog, f"u_gbuffer{a}", unit)
            _set(prog, "u_projection", gl_bytes(camera.projection_matrix()))
            if self._empty_vao is None or self._empty_vao.program is not prog:
                if self._empty_vao is not None:
                    self._empty_vao.release()
                self._empty_vao = ctx.vertex_array(prog, [])
            targets.fbo.use()
            ctx.viewport = (0, 0, w, h)
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.BLEND)
            self._empty_vao.render(ctx.TRIANGLES, vertices=3)
        finally:
            ctx.disable(ctx.DEPTH_TEST)

    def _stack_textures(self, image: ImageGBuffer) -> list[tuple[int, object]]:
        """The stack packed into this layout's attachments, uploaded once per image (the cache
        holds the image, so its id cannot be reused while the textures live)."""
        entry = self._stacks.get(id(image))
        if entry is None:
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
            entry = self._stacks[id(image)] = (image, textures)
        return entry[1]

    def release(self) -> None:
        """Free every uploaded mesh and texture."""
        self.uploads.release()
        for _, textures in self._stacks.values():
            for _, tex in textures:
                tex.release()
        self._stacks.clear()
        if self._empty_vao is not None:
            self._empty_vao.release()
            self._empty_vao = None
