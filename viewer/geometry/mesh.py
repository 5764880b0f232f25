"""Triangle meshes in world space, as the G-buffer pass consumes them.

A :class:`Mesh` is plain numpy data: no GL objects (the G-buffer pass uploads and caches them).
Texture maps follow glTF 2.0: texture coordinates have (0, 0) at the *top-left* of the image, so a
numpy image (row 0 at the top) is uploaded as is and sampled with the mesh's UVs directly.

===================== ===== =====================================================================
texture key           C     meaning
===================== ===== =====================================================================
base_color            3/4   linear RGB(A), float32 (already sRGB-decoded); multiplies the albedo
metallic_roughness    3/4   linear; G = roughness, B = metallic (glTF), multiply the factors
normal                3/4   tangent-space normal encoded n * 0.5 + 0.5, linear; +Y = towards -v
occlusion             1..4  linear; R = ambient occlusion
emissive              3/4   linear RGB (already sRGB-decoded); multiplies ``Mesh.emissive``
specular              4     linear; A = KHR_materials_specular factor (with ``Material.ior`` only)
specular_color        3/4   linear RGB (already sRGB-decoded); multiplies ``Material.specular_color``
clearcoat             1..4  linear; R multiplies ``Material.clearcoat`` (KHR_materials_clearcoat)
clearcoat_roughness   2..4  linear; G multiplies ``Material.clearcoat_roughness``
clearcoat_normal      3/4   the coat's tangent-space normal, as ``normal`` (x, y scaled by
                            ``Mesh.clearcoat_normal_scale``); without it the coat has the vertex normal
sheen_color           3/4   linear RGB (already sRGB-decoded); multiplies ``Material.sheen_color``
sheen_roughness       4     linear; A multiplies ``Material.sheen_roughness`` (KHR_materials_sheen)
iridescence           1..4  linear; R multiplies ``Material.iridescence`` (KHR_materials_iridescence)
iridescence_thickness 2..4  linear; G blends the film's thickness from ``iridescence_thickness_min``
                            to ``_max`` (without it: the maximum)
anisotropy            3/4   linear; RG = the direction in tangent space (x 2 - 1, before
                            ``Material.anisotropy_rotation``), B multiplies its strength
                            (KHR_materials_anisotropy)
transmission          1..4  linear; R multiplies ``Material.transmission``
                            (KHR_materials_transmission)
thickness             2..4  linear; G multiplies ``Material.thickness`` (KHR_materials_volume; the
                            rasteriser's refraction reads it, the traced volume is the mesh)
===================== ===== =====================================================================

How each map is sampled (texture coordinate set, ``KHR_texture_transform``, wrap and filter modes)
is a :class:`TextureSampling` in ``Mesh.sampling`` (absent: set 0, identity, repeat, trilinear).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..scene.material import Material

TEXTURE_KEYS = ("base_color", "metallic_roughness", "normal", "occlusion", "emissive", "specular",
                "specular_color", "clearcoat", "clearcoat_roughness", "clearcoat_normal",
                "sheen_color", "sheen_roughness", "anisotropy", "iridescence",
                "iridescence_thickness", "transmission", "thickness")
WRAP_MODES = ("repeat", "clamp", "mirror")  # glTF REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT
MIN_FILTERS = ("nearest", "linear", "nearest_mipmap_nearest", "linear_mipmap_nearest",
               "nearest_mipmap_linear", "linear_mipmap_linear")
ALPHA_MODES = ("OPAQUE", "MASK", "BLEND")


@dataclass(frozen=True)
class TextureSampling:
    """How one texture map is read: glTF ``textureInfo.texCoord``, its sampler and the
    ``KHR_texture_transform`` of the textureInfo (whose ``texCoord``, if any, is already in
    ``texcoord``)."""

    texcoord: int = 0  # 0: Mesh.uvs (TEXCOORD_0), 1: Mesh.uvs1 (TEXCOORD_1)
    offset: tuple[float, float] = (0.0, 0.0)
    rotation: float = 0.0  # radians
    scale: tuple[float, float] = (1.0, 1.0)
    wrap: tuple[str, str] = ("repeat", "repeat")  # (s = u, t = v), from WRAP_MODES
    mag_filter: str = "linear"  # "linear" | "nearest"
    min_filter: str = "linear_mipmap_linear"  # from MIN_FILTERS

    def uv_matrix(self) -> np.ndarray:
        """The ``[3, 3]`` affine map uv -> (M @ [u, v, 1])[:2] of ``KHR_texture_transform``:
        M = T(offset) R(rotation) S(scale), with R = [[cos, sin], [-sin, cos]] (rows).

        The rotation's sign is the one of the extension's JSON example ("offset [0, 1], rotation
        pi/2, scale 0.5 uses the lower left quadrant of the image, rotated clockwise 90 degrees":
        (u, v) in [0, 1]^2 -> (v/2, 1 - u/2)) and of three.js (``Matrix3.setUvTransform``) and the
        Khronos sample viewer; the spec's draft GLSL, ``mat3(cos, sin, 0, -sin, cos, 0, 0, 0, 1)``,
        read as GLSL's column-major constructor, would rotate the other way.
        """
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        t = np.array([[1.0, 0.0, self.offset[0]], [0.0, 1.0, self.offset[1]], [0.0, 0.0, 1.0]])
        r = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        sc = np.diag([self.scale[0], self.scale[1], 1.0])
        return t @ r @ sc

    def validated(self, where: str) -> "TextureSampling":
        ok = (self.texcoord in (0, 1) and all(w in WRAP_MODES for w in self.wrap)
              and len(self.wrap) == 2 and self.mag_filter in ("linear", "nearest")
              and self.min_filter in MIN_FILTERS
              and np.isfinite([*self.offset, self.rotation, *self.scale]).all())
        if not ok:
            raise InputError(f"invalid texture sampling {self}", where=where)
        return self


@dataclass(kw_only=True)
class Mesh:
    """An indexed triangle mesh with a metallic-roughness material."""

    positions: np.ndarray  # [N, 3] float32, world space
    normals: np.ndarray  # [N, 3] float32, unit, world space
    uvs: np.ndarray | None = None  # [N, 2] float32, glTF convention (v = 0 at the image top)
    tangents: np.ndarray | None = None  # [N, 4] float32: xyz unit world space, w = +-1 handedness
    indices: np.ndarray  # [M, 3] uint32, counter-clockwise front faces
    material: Material = field(default_factory=Material)
    textures: dict[str, np.ndarray] = field(default_factory=dict)  # keys from TEXTURE_KEYS
    normal_scale: float = 1.0  # glTF normalTexture.scale: scales the tangent-space x and y
    occlusion_strength: float = 1.0  # glTF occlusionTexture.strength
    uvs1: np.ndarray | None = None  # [N, 2] float32: the second texture coordinate set
    colors: np.ndarray | None = None  # [N, 4] float32 linear RGBA (glTF COLOR_0): x base colour
    sampling: dict[str, TextureSampling] = field(default_factory=dict)  # texture key -> sampling
    # glTF: false culls back faces; true (primitives, OBJ) draws them with the normal flipped
    double_sided: bool = True
    alpha_mode: str = "OPAQUE"  # ALPHA_MODES: MASK discards below alpha_cutoff
    alpha_cutoff: float = 0.5
    base_alpha: float = 1.0  # glTF baseColorFactor[3]
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)  # linear radiance (factor x strength)
    # glTF KHR_materials_unlit: the base colour shown as is. The loader makes the material black
    # (no lobe) and the emission the base colour (factor, texture; COLOR_0 multiplies it)
    unlit: bool = False
    clearcoat_normal_scale: float = 1.0  # KHR_materials_clearcoat clearcoatNormalTexture.scale
    name: str = ""
    source: str | None = None  # the file it came from, for messages

    @property
    def vertex_count(self) -> int:
        return int(self.positions.shape[0])

    @property
    def triangle_count(self) -> int:
        return int(self.indices.shape[0])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)``: the axis-aligned bounding box, two ``[3]`` float64 arrays."""
        if self.vertex_count == 0:
            z = np.zeros(3)
            return z, z.copy()
        p = np.asarray(self.positions, np.float64)
        return p.min(axis=0), p.max(axis=0)

    def validated(self, where: str | None = None) -> "Mesh":
        """Check shapes, dtypes and finiteness; raise :class:`InputError` naming ``where``.

        Returns ``self`` with arrays converted to the documented dtypes.
        """
        where = where or self.source or self.name or "mesh"
        self.positions = np.ascontiguousarray(self.positions, np.float32)
        self.normals = np.ascontiguousarray(self.normals, np.float32)
        self.indices = np.ascontiguousarray(self.indices, np.uint32).reshape(-1, 3)
        n = self.vertex_count
        if self.positions.ndim != 2 or self.positions.shape[1] != 3:
            raise InputError(f"positions have shape {self.positions.shape}, expected [N, 3]",
                             where=where)
        if self.normals.shape != self.positions.shape:
            raise InputError(f"normals have shape {self.normals.shape}, expected {[n, 3]}",
                             where=where)
        for label, arr in (("positions", self.positions), ("normals", self.normals)):
            bad = ~np.isfinite(arr).all(axis=1)
            if bad.any():
                raise InputError(f"{int(bad.sum())} vertices have NaN/Inf {label}", where=where)
        if self.uvs is not None:
            self.uvs = np.ascontiguousarray(self.uvs, np.float32)
            if self.uvs.shape != (n, 2) or not np.isfinite(self.uvs).all():
                raise InputError(f"texture coordinates have shape {self.uvs.shape} or NaN/Inf "
                                 f"values, expected finite [{n}, 2]", where=where)
        if self.tangents is not None:
            self.tangents = np.ascontiguousarray(self.tangents, np.float32)
            if self.tangents.shape != (n, 4) or not np.isfinite(self.tangents).all():
                raise InputError(f"tangents have shape {self.tangents.shape} or NaN/Inf values, "
                                 f"expected finite [{n}, 4]", where=where)
        if self.triangle_count == 0:
            raise InputError("mesh has no triangles", where=where)
        if int(self.indices.max()) >= n:
            raise InputError(f"triangle index {int(self.indices.max())} is out of range for "
                             f"{n} vertices", where=where)
        for key in self.textures:
            if key not in TEXTURE_KEYS:
                raise InputError(f"unknown texture {key!r} (known: {', '.join(TEXTURE_KEYS)})",
                                 where=where)
        if self.uvs1 is not None:
            self.uvs1 = np.ascontiguousarray(self.uvs1, np.float32)
            if self.uvs1.shape != (n, 2) or not np.isfinite(self.uvs1).all():
                raise InputError(f"texture coordinates 1 have shape {self.uvs1.shape} or NaN/Inf "
                                 f"values, expected finite [{n}, 2]", where=where)
        if self.colors is not None:
            self.colors = np.ascontiguousarray(self.colors, np.float32)
            if self.colors.shape != (n, 4) or not np.isfinite(self.colors).all():
                raise InputError(f"vertex colours have shape {self.colors.shape} or NaN/Inf "
                                 f"values, expected finite [{n}, 4]", where=where)
        for key, sampling in self.sampling.items():
            sampling.validated(f"{where} ({key} texture)")
        if self.alpha_mode not in ALPHA_MODES:
            raise InputError(f"alpha mode {self.alpha_mode!r} is not one of "
                             f"{', '.join(ALPHA_MODES)}", where=where)
        if not (np.isfinite(self.emissive).all() and min(self.emissive) >= 0.0):
            raise InputError(f"emissive {list(self.emissive)} must be finite and >= 0",
                             where=where)
        return self

    @property
    def has_emission(self) -> bool:
        """Whether any point of the surface emits light."""
        if max(self.emissive) <= 0.0:
            return False
        tex = self.textures.get("emissive")
        return tex is None or float(np.max(tex[..., :3])) > 0.0

    def transformed(self, matrix: np.ndarray) -> "Mesh":
        """A copy with positions, normals and tangents transformed by the ``[4, 4]`` ``matrix``.

        Normals use the inverse transpose; a mirroring matrix (negative determinant) reverses
        the triangle winding and the tangent handedness so front faces stay front faces.
        """
        m = np.asarray(matrix, np.float64)
        lin = m[:3, :3]
        p = np.asarray(self.positions, np.float64) @ lin.T + m[:3, 3]
        normal_m = np.linalg.inv(lin).T
        nrm = _normalize(np.asarray(self.normals, np.float64) @ normal_m.T)
        det = float(np.linalg.det(lin))
        tangents = None
        if self.tangents is not None:
            t = np.asarray(self.tangents, np.float64)
            txyz = _normalize(t[:, :3] @ lin.T)
            w = t[:, 3:4] * (1.0 if det >= 0 else -1.0)
            tangents = np.concatenate([txyz, w], axis=1).astype(np.float32)
        indices = self.indices if det >= 0 else self.indices[:, ::-1]
        return dataclasses.replace(self, positions=p.astype(np.float32),
                                   normals=nrm.astype(np.float32), tangents=tangents,
                                   indices=np.ascontiguousarray(indices))


def smooth_normals(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Area-weighted smooth vertex normals ``[N, 3]`` float32 for an indexed triangle mesh.

    Vertices that touch no (non-degenerate) triangle get +Y rather than NaN.
    """
    p = np.asarray(positions, np.float64)
    tri = np.asarray(indices, np.int64).reshape(-1, 3)
    face_n = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])  # |n| = 2 area
    acc = np.zeros_like(p)
    for k in range(3):
        np.add.at(acc, tri[:, k], face_n)
    return _normalize(acc).astype(np.float32)


def _normalize(v: np.ndarray, fallback=(0.0, 1.0, 0.0)) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    ok = n[..., 0] > 1e-20
    out = np.empty_like(v)
    out[ok] = v[ok] / n[ok]
    out[~ok] = np.asarray(fallback, v.dtype)
    return out


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 sRGB decoding of values in [0, 1] (float32 out)."""
    c = np.clip(np.asarray(c, np.float32), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


class MeshList(list):
    """What a mesh file loads as: its meshes (a list) and the lights it places, ``lights``
    (:class:`viewer.lighting.lights.Light`, world space after every transform; glTF
    ``KHR_lights_punctual``), which the renderer shades with the scene's own
    (:func:`viewer.lighting.lights.gather_lights`)."""

    def __init__(self, meshes=(), lights=()):
        super().__init__(meshes)
        self.lights = tuple(lights)
