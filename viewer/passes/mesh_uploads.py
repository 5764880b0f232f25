"""GPU copies of triangle meshes for the passes that rasterise them (the G-buffer fill and the
forward pass of transparent surfaces): vertex and index buffers, a vertex array per program
variant, texture maps and sampler objects.

Texture maps: each image is uploaded once (RGBA16F, mipmapped); its glTF sampler becomes a
moderngl sampler object (REPEAT / CLAMP_TO_EDGE per axis, the filters, 8x anisotropy with
mipmapped linear filtering), MIRRORED_REPEAT is applied in the shader (moderngl has no such wrap
mode). Why anisotropy matters for speed on llvmpipe: its anisotropic filter's cost grows with the
footprint once that exceeds the coarsest mip level - a 128^2 sphere whose uvs span 0..4279 (the
quantised Duck's integer texture coordinates without their KHR_texture_transform) took 0.6 s per
draw against 0.014 s at uv 0..1 and 0.009 s without anisotropy. The time showed up in whatever GL
call next waited for the queued draw (the environment's mipmap building), not in the draw call.

Copies are cached by the identity of the mesh (and image) they were made from
(:class:`~viewer.passes.uploads.UploadCache`): released when it dies or when the geometry cache
evicts the content holding it, never handed out for another object that reused its ``id()``.
Textures and samplers are looked up on every draw, vertex arrays rebuilt when the program they
were made for was evicted (:mod:`viewer.gl.programs`), so no draw reads a released object.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..cache import BoundedCache, CacheStats, texture_bytes
from ..geometry.mesh import Mesh, TextureSampling
from ..gl.context import is_software
from ..gl.programs import on_release
from ..scene.camera import Camera, gl_bytes
from . import set_uniform as _set
from .uploads import UploadCache

_MAP_DEFINES = {"base_color": "USE_BASE_COLOR_MAP",
                "metallic_roughness": "USE_METALLIC_ROUGHNESS_MAP",
                "normal": "USE_NORMAL_MAP", "occlusion": "USE_OCCLUSION_MAP",
                "emissive": "USE_EMISSIVE_MAP", "specular": "USE_SPECULAR_MAP",
                "specular_color": "USE_SPECULAR_COLOR_MAP", "clearcoat": "USE_CLEARCOAT_MAP",
                "clearcoat_roughness": "USE_CLEARCOAT_ROUGHNESS_MAP",
                "clearcoat_normal": "USE_CLEARCOAT_NORMAL_MAP", "sheen_color": "USE_SHEEN_COLOR_MAP",
                "sheen_roughness": "USE_SHEEN_ROUGHNESS_MAP",
                "anisotropy": "USE_ANISOTROPY_MAP",
                "iridescence": "USE_IRIDESCENCE_MAP",
                "iridescence_thickness": "USE_IRIDESCENCE_THICKNESS_MAP",
                "transmission": "USE_TRANSMISSION_MAP", "thickness": "USE_THICKNESS_MAP"}
_DIELECTRIC_MAPS = ("specular", "specular_color")  # read only with the glTF lobe (Material.ior)
_CLEARCOAT_MAPS = ("clearcoat", "clearcoat_roughness", "clearcoat_normal")  # with a coat only
_SHEEN_MAPS = ("sheen_color", "sheen_roughness")  # with a sheen only
_FILM_MAPS = ("iridescence", "iridescence_thickness")  # with KHR_materials_iridescence only
# KHR_materials_transmission's map with a transmission factor > 0 only, KHR_materials_volume's
# thickness map with a volume only (Material.volume: a thin wall has no thickness to scale)
_DEFAULT_SAMPLING = TextureSampling()
ANISOTROPY = 8.0  # for mipmapped linear filtering
# llvmpipe (Mesa 22.3) reads texels from elsewhere in the texture where textureGrad meets a
# sampler with anisotropy above 1 (the plasma gun's rim under lobby: 55 dark 2 x 2 quads in the
# base colour, stray emissive dots; measured 2026-11-29). sample_map takes textureGrad only for
# mirrored wraps, so only their samplers drop to 1 there (tests/viewer/test_texture_specks.py)
SOFTWARE_MIRROR_ANISOTROPY = 1.0
MAX_SAMPLERS = 32  # distinct wrap/filter combinations kept as sampler objects


def _released(obj) -> bool:
    """Whether a moderngl object is missing or was released."""
    return obj is None or type(getattr(obj, "mglo", None)).__name__ == "InvalidObject"


def mesh_defines(mesh: Mesh) -> dict[str, int]:
    """The mesh program variant for ``mesh``: one define per texture map it has (and can use),
    the texture coordinate sets they read, vertex colours, the alpha mask."""
    defines = {}
    uv_sets = (mesh.uvs, mesh.uvs1)
    if mesh.material.ior is not None:
        defines["USE_DIELECTRIC"] = 1
    coat = mesh.material.clearcoat > 0.0
    if coat:
        defines["USE_CLEARCOAT"] = 1
    if mesh.material.transmission > 0.0:
        defines["USE_TRANSMISSION"] = 1
    if mesh.material.has_dispersion:  # a dispersive volume (no effect elsewhere: no cost)
        defines["USE_DISPERSION"] = 1
    sheen = mesh.material.has_sheen
    if sheen:
        defines["USE_SHEEN"] = 1
    aniso = mesh.material.has_anisotropy
    if aniso:
        defines["USE_ANISOTROPY"] = 1
    film = mesh.material.has_iridescence
    if film:
        defines["USE_IRIDESCENCE"] = 1
    for key in mesh.textures:
        if key not in _MAP_DEFINES or (key in _DIELECTRIC_MAPS and mesh.material.ior is None) \
                or (key in _CLEARCOAT_MAPS and not coat) or (key in _SHEEN_MAPS and not sheen) \
                or (key == "anisotropy" and not aniso) or (key in _FILM_MAPS and not film) \
                or (key == "transmission" and mesh.material.transmission <= 0.0) \
                or (key == "thickness" and not mesh.material.volume):
            continue
        texcoord = mesh.sampling.get(key, _DEFAULT_SAMPLING).texcoord
        if uv_sets[texcoord] is None:
            continue
        defines[_MAP_DEFINES[key]] = 1
        defines[f"USE_UV{texcoord}"] = 1
    if ("USE_NORMAL_MAP" in defines or "USE_CLEARCOAT_NORMAL_MAP" in defines or aniso) and \
            mesh.tangents is not None:
        defines["HAS_TANGENTS"] = 1
    if aniso and mesh.tangents is None and uv_sets[anisotropy_frame_set(mesh)] is not None:
        defines[f"USE_UV{anisotropy_frame_set(mesh)}"] = 1  # its cotangent frame
    if mesh.colors is not None:
        defines["USE_VERTEX_COLOR"] = 1
        if mesh.unlit:
            defines["UNLIT_VERTEX_COLOR"] = 1  # KHR_materials_unlit: COLOR_0 x its emission
    if mesh.alpha_mode == "MASK":
        defines["ALPHA_MASK"] = 1
    elif mesh.alpha_mode == "BLEND":  # the forward pass: blended by its alpha
        defines["ALPHA_BLEND"] = 1
    return defines


def anisotropy_frame_set(mesh: Mesh) -> int:
    """The texture coordinate set whose gradients give a KHR_materials_anisotropy surface its
    tangent space where the mesh has no tangents: its anisotropy map's, else its normal map's
    (the spec: both live in the same tangent space), else 0."""
    for key in ("anisotropy", "normal"):
        if key in mesh.textures:
            return int(mesh.sampling.get(key, _DEFAULT_SAMPLING).texcoord)
    return 0


@dataclass(eq=False)
class _MeshCopy:
    """The cached GPU copy of one mesh for one variant."""

    defines: dict[str, int]
    buffers: list  # vertex buffers, then the index buffer
    content: list  # (buffer, format, attribute name) of the attributes the program reads
    vao: object | None = None  # made for ``program``
    program: object | None = None

    def release(self) -> None:
        if self.vao is not None:
            self.vao.release()
        self.vao = self.program = None
        for buf in self.buffers:
            buf.release()
        self.buffers = []


@dataclass
class MeshDraw:
    """What one draw of a mesh binds (:meth:`MeshUploads.upload`): valid for this draw."""

    mesh: Mesh
    vao: object  # its .program is the variant's program
    # map key -> (texture, sampler object, TextureSampling)
    textures: dict[str, tuple]
    defines: dict[str, int]


class MeshUploads:
    """GPU copies of meshes for the programs of one pass (``program(defines, variant)``: the
    G-buffer fill, or the forward pass with its lighting variant): vertex buffers and a vertex
    array per mesh and variant, each image once (RGBA16F, mipmapped), one sampler object per
    distinct wrap/filter combination. Cached by mesh identity: after editing a mesh's arrays in
    place, :meth:`release` (or draw a new :class:`Mesh`)."""

    def __init__(self, ctx, program):
        self.ctx = ctx
        self._program = program  # (mesh defines, variant) -> program
        self.meshes = UploadCache(ctx, "mesh uploads", release=lambda c: c.release())
        self.textures = UploadCache(ctx, "texture uploads", release=lambda t: t.release())
        # (wrap, mag, min filter) -> sampler object (looked up per draw, so eviction is safe)
        self.samplers = BoundedCache("samplers", max_items=MAX_SAMPLERS,
                                     release=lambda s: s.release())

    def _texture(self, image: np.ndarray):
        def make():
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
            return tex, texture_bytes(tex)
        return self.textures.get_or_create(image, None, make)

    def _sampler(self, sampling: TextureSampling):
        """A sampler object for ``sampling``'s wrap and filter modes (shared by equal ones)."""
        ctx = self.ctx

        def make():
            min_filter = {"nearest": ctx.NEAREST, "linear": ctx.LINEAR,
                          "nearest_mipmap_nearest": ctx.NEAREST_MIPMAP_NEAREST,
                          "linear_mipmap_nearest": ctx.LINEAR_MIPMAP_NEAREST,
                          "nearest_mipmap_linear": ctx.NEAREST_MIPMAP_LINEAR,
                          "linear_mipmap_linear": ctx.LINEAR_MIPMAP_LINEAR}[sampling.min_filter]
            mag_filter = ctx.LINEAR if sampling.mag_filter == "linear" else ctx.NEAREST
            aniso = ANISOTROPY if sampling.min_filter.startswith("linear_mipmap") else 1.0
            if "mirror" in sampling.wrap and is_software(ctx):  # sample_map's textureGrad
                aniso = min(aniso, SOFTWARE_MIRROR_ANISOTROPY)
            return ctx.sampler(
                repeat_x=sampling.wrap[0] == "repeat", repeat_y=sampling.wrap[1] == "repeat",
                filter=(min_filter, mag_filter), anisotropy=aniso)
        return self.samplers.get_or_create(
            (sampling.wrap, sampling.mag_filter, sampling.min_filter), make)

    def _copy(self, mesh: Mesh, variant) -> _MeshCopy:
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
        buffers.append(self.ctx.buffer(np.ascontiguousarray(mesh.indices, np.uint32).tobytes()))
        return _MeshCopy(defines=defines, buffers=buffers, content=content)

    def upload(self, mesh: Mesh, variant=None) -> MeshDraw:
        """The mesh's vertex array (with its program for ``variant``, any hashable the program
        callback understands) and textures, uploaded on first use."""
        # an upload counts towards the geometry entry holding its mesh or image, which may evict
        # other entries: where a texture image is shared with another entry, that may release
        # part of this very draw, which is then made again
        for _ in range(3):
            draw = self._prepare(mesh, variant)
            if not any(_released(o) for o in (draw.vao, *(t for t, _, _ in
                                                            draw.textures.values()))):
                return draw
        raise RuntimeError(f"the GPU copies of mesh {mesh.name or mesh.source or id(mesh)} were "
                           f"evicted while it was drawn: the geometry budget "
                           f"(Budgets.geometry_bytes) is too small for the scene")

    def _prepare(self, mesh: Mesh, variant) -> MeshDraw:
        copy = self.meshes.get(mesh, variant)
        if copy is None:
            copy = self._copy(mesh, variant)
            self.meshes.put(mesh, variant, copy, sum(b.size for b in copy.buffers))
        textures = {}
        for k in mesh.textures:
            if _MAP_DEFINES.get(k) in copy.defines:
                sampling = mesh.sampling.get(k, _DEFAULT_SAMPLING)
                textures[k] = (self._texture(mesh.textures[k]), self._sampler(sampling), sampling)
        if not copy.buffers:  # released meanwhile (see upload)
            return MeshDraw(mesh=mesh, vao=None, textures=textures, defines=copy.defines)
        prog = self._program(copy.defines, variant)
        if copy.vao is None or copy.program is not prog:
            if copy.vao is not None:
                copy.vao.release()
            copy.vao = self.ctx.vertex_array(prog, copy.content, index_buffer=copy.buffers[-1],
                                             index_element_size=4)
            copy.program = prog
            on_release(prog, self._program_released)
        return MeshDraw(mesh=mesh, vao=copy.vao, textures=textures, defines=copy.defines)

    def _program_released(self, program) -> None:
        """A program was evicted: release the vertex arrays made for it (rebuilt on next use)."""
        for copy in self.meshes.values():
            if copy.program is program:
                copy.vao.release()
                copy.vao = copy.program = None

    @staticmethod
    def set_camera(prog, camera: Camera) -> None:
        _set(prog, "u_view", gl_bytes(camera.view_matrix()))
        _set(prog, "u_projection", gl_bytes(camera.projection_matrix()))

    @staticmethod
    def bind_material(prog, entry: MeshDraw, first_unit: int = 0) -> list[int]:
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
        if m.ior is not None:
            _set(prog, "u_ior", float(m.ior))
            _set(prog, "u_specular_color", tuple(float(c) for c in m.specular_color))
            _set(prog, "u_specular_factor", float(m.specular_factor))
        if m.clearcoat > 0.0:
            _set(prog, "u_clearcoat", float(m.clearcoat))
            _set(prog, "u_clearcoat_roughness", float(m.clearcoat_roughness))
            _set(prog, "u_clearcoat_normal_scale", float(mesh.clearcoat_normal_scale))
        if m.transmission > 0.0:
            _set(prog, "u_transmission", float(m.transmission))
            _set(prog, "u_transmission_ior", float(m.transmission_row()[1]))
        if m.has_dispersion:
            _set(prog, "u_dispersion", float(m.dispersion))
        if m.has_sheen:
            _set(prog, "u_sheen_color", tuple(float(c) for c in m.sheen_color))
            _set(prog, "u_sheen_roughness", float(m.sheen_roughness))
        if m.has_anisotropy:
            _set(prog, "u_anisotropy_strength", float(m.anisotropy_strength))
            _set(prog, "u_anisotropy_rotation", (math.cos(m.anisotropy_rotation),
                                                 math.sin(m.anisotropy_rotation)))
            _set(prog, "u_anisotropy_frame_set", anisotropy_frame_set(mesh))
        if m.has_iridescence:  # factor, thickness (the maximum), IOR, the thickness map's minimum
            _set(prog, "u_iridescence", m.iridescence_row())
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
    def unbind(entry: MeshDraw, units: list[int]) -> None:
        """Unbind the sampler objects :meth:`bind_material` bound (plain textures keep their own
        filtering again)."""
        for unit, (_, sampler, _) in zip(units, entry.textures.values()):
            sampler.clear(unit)

    def stats(self) -> dict[str, CacheStats]:
        return {"meshes": self.meshes.stats(), "textures": self.textures.stats(),
                "samplers": self.samplers.stats()}

    def release(self) -> None:
        self.meshes.release()
        self.textures.release()
        self.samplers.clear()
