"""Triangle meshes in world space, as the G-buffer pass consumes them.

A :class:`Mesh` is plain numpy data: no GL objects (the G-buffer pass uploads and caches them).
Texture maps follow glTF 2.0: texture coordinates have (0, 0) at the *top-left* of the image, so a
numpy image (row 0 at the top) is uploaded as is and sampled with the mesh's UVs directly.

=================== ===== =====================================================================
texture key          C    meaning
=================== ===== =====================================================================
base_color          3/4   linear RGB(A), float32 (already sRGB-decoded); multiplies the albedo
metallic_roughness  3/4   linear; G = roughness, B = metallic (glTF), multiply the factors
normal              3/4   tangent-space normal encoded n * 0.5 + 0.5, linear; +Y = towards -v
occlusion           1..4  linear; R = ambient occlusion
=================== ===== =====================================================================
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..material import Material

TEXTURE_KEYS = ("base_color", "metallic_roughness", "normal", "occlusion")


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
        return self

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
        return Mesh(positions=p.astype(np.float32), normals=nrm.astype(np.float32),
                    uvs=self.uvs, tangents=tangents, indices=np.ascontiguousarray(indices),
                    material=self.material, textures=self.textures,
                    normal_scale=self.normal_scale, occlusion_strength=self.occlusion_strength,
                    name=self.name, source=self.source)


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
