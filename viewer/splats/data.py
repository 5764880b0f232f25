"""The :class:`Splats` container: a cloud of 3D Gaussians as numpy arrays, in world space.

Conventions (shared by the GLSL pass ``shaders/passes/splat_*`` and the torch twin
``learned/splats/rasterize.py``):

* ``rotations`` are unit quaternions ``(w, x, y, z)``; ``scales`` are standard deviations sigma
  (linear, not log). The covariance is Sigma = R S S^T R^T (Kerbl et al. 2023, eq. 6).
* ``sh`` holds K = (degree + 1)^2 RGB coefficients in the INRIA 3DGS order and sign convention;
  the baked colour seen along the unit direction d (camera -> splat centre) is
  ``max(sum_k sh_basis_k(d) sh_k + 0.5, 0)``.
* ``normals`` of zero length mean "none stored": the pass uses the Gaussian's shortest axis. Every
  normal is flipped to face the camera at render time.
* Material arrays always exist; baked-colour splats get albedo = clamp(DC colour, 0, 1),
  roughness :data:`DEFAULT_ROUGHNESS` and metallic 0 (``has_materials`` is then False).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

SH_C0 = 0.28209479177387814
DEFAULT_ROUGHNESS = 0.5
SH_COUNTS = {1: 0, 4: 1, 9: 2, 16: 3}  # K -> degree


@dataclass(frozen=True, eq=False)
class Splats:
    """N Gaussians. Compared and hashed by identity (arrays are large); treat as immutable."""

    means: np.ndarray  # [N, 3] float32 world space
    scales: np.ndarray  # [N, 3] float32 sigma per local axis, > 0
    rotations: np.ndarray  # [N, 4] float32 unit quaternion (w, x, y, z)
    opacities: np.ndarray  # [N] float32 in (0, 1)
    sh: np.ndarray  # [N, K, 3] float32, K in (1, 4, 9, 16)
    albedo: np.ndarray  # [N, 3] float32 linear in [0, 1]
    roughness: np.ndarray  # [N] float32 perceptual in [0, 1]
    metallic: np.ndarray  # [N] float32 in [0, 1]
    normals: np.ndarray  # [N, 3] float32 world space, unit or zero (= use the shortest axis)
    has_materials: bool = False  # albedo/roughness/metallic came from the data, not defaults
    source: str | None = field(default=None)

    def __len__(self) -> int:
        return int(self.means.shape[0])

    @property
    def sh_degree(self) -> int:
        return SH_COUNTS[int(self.sh.shape[1])]

    def subset(self, keep: np.ndarray) -> "Splats":
        return replace(self, **{k: getattr(self, k)[keep] for k in _ARRAYS})

    def with_sh_degree(self, degree: int) -> "Splats":
        """Pad with zeros (or truncate) the SH coefficients to ``degree``."""
        k = (degree + 1) ** 2
        sh = np.zeros((len(self), k, 3), np.float32)
        n = min(k, self.sh.shape[1])
        sh[:, :n] = self.sh[:, :n]
        return replace(self, sh=sh)

    def covariances(self) -> np.ndarray:
        """``[N, 3, 3]`` float64 world-space covariances R S S^T R^T."""
        r = quat_to_matrix(self.rotations.astype(np.float64))
        s = self.scales.astype(np.float64)
        m = r * s[:, None, :]
        return m @ np.swapaxes(m, 1, 2)


_ARRAYS = ("means", "scales", "rotations", "opacities", "sh", "albedo", "roughness", "metallic",
           "normals")


def make_splats(means, scales, rotations, opacities, sh=None, albedo=None, roughness=None,
                metallic=None, normals=None, source=None) -> Splats:
    """Build :class:`Splats` from array-likes, filling defaults (see the module docstring)."""
    means = np.asarray(means, np.float32).reshape(-1, 3)
    n = means.shape[0]
    rot = np.asarray(rotations, np.float32).reshape(n, 4)
    norm = np.linalg.norm(rot, axis=1, keepdims=True)
    rot = rot / np.maximum(norm, 1e-30)
    if sh is None:
        base = np.full((n, 3), 0.5, np.float32) if albedo is None else np.asarray(albedo, np.float32)
        sh = ((base - 0.5) / SH_C0).reshape(n, 1, 3)
    sh = np.asarray(sh, np.float32)
    sh = sh.reshape(n, sh.shape[1] if sh.ndim == 3 else max(sh.size // max(3 * n, 1), 1), 3)
    has_materials = albedo is not None
    if albedo is None:
        albedo = np.clip(sh[:, 0] * SH_C0 + 0.5, 0.0, 1.0)
    return Splats(
        means=np.ascontiguousarray(means),
        scales=np.asarray(scales, np.float32).reshape(n, 3),
        rotations=rot.astype(np.float32),
        opacities=np.asarray(opacities, np.float32).reshape(n),
        sh=np.ascontiguousarray(sh),
        albedo=np.asarray(albedo, np.float32).reshape(n, 3),
        roughness=(np.full(n, DEFAULT_ROUGHNESS, np.float32) if roughness is None
                   else np.asarray(roughness, np.float32).reshape(n)),
        metallic=(np.zeros(n, np.float32) if metallic is None
                  else np.asarray(metallic, np.float32).reshape(n)),
        normals=(np.zeros((n, 3), np.float32) if normals is None
                 else np.asarray(normals, np.float32).reshape(n, 3)),
        has_materials=has_materials, source=source)


def empty_splats(source=None) -> Splats:
    z = np.zeros((0, 3), np.float32)
    return make_splats(z, z, np.zeros((0, 4), np.float32), np.zeros(0, np.float32), source=source)


def concat(parts: list[Splats]) -> Splats:
    """One cloud from several (SH padded to the highest degree), so they sort together."""
    if len(parts) == 1:
        return parts[0]
    degree = max(p.sh_degree for p in parts)
    parts = [p.with_sh_degree(degree) for p in parts]
    kw = {k: np.concatenate([getattr(p, k) for p in parts], axis=0) for k in _ARRAYS}
    return Splats(**kw, has_materials=all(p.has_materials for p in parts), source=parts[0].source)


# ---- quaternions and SH ----------------------------------------------------------------------

def min_axis(rot: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """[N, 3] the unit shortest axis of each Gaussian (ties: lowest index), as in
    ``splat_min_axis`` (shaders/lib/splat.glsl): the column of R for the smallest of ``scale``
    (sigmas or their logs: the same order); zero quaternions give the identity."""
    norm = np.linalg.norm(rot, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        q = np.where(norm > 0, rot / np.where(norm > 0, norm, 1.0), [[1.0, 0.0, 0.0, 0.0]])
    r = quat_to_matrix(q)
    k = np.argmin(scale, axis=1)
    return r[np.arange(len(k)), :, k]


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """``[N, 4]`` unit quaternions (w, x, y, z) -> ``[N, 3, 3]`` rotation matrices."""
    w, x, y, z = (q[:, i] for i in range(4))
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], axis=1)


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """``[N, 3, 3]`` rotations -> ``[N, 4]`` unit quaternions (w, x, y, z), w >= 0."""
    m = np.asarray(m, np.float64)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cands = np.stack([
        np.stack([1 + tr, m[:, 2, 1] - m[:, 1, 2], m[:, 0, 2] - m[:, 2, 0], m[:, 1, 0] - m[:, 0, 1]], -1),
        np.stack([m[:, 2, 1] - m[:, 1, 2], 1 + m[:, 0, 0] - m[:, 1, 1] - m[:, 2, 2],
                  m[:, 0, 1] + m[:, 1, 0], m[:, 0, 2] + m[:, 2, 0]], -1),
        np.stack([m[:, 0, 2] - m[:, 2, 0], m[:, 0, 1] + m[:, 1, 0],
                  1 - m[:, 0, 0] + m[:, 1, 1] - m[:, 2, 2], m[:, 1, 2] + m[:, 2, 1]], -1),
        np.stack([m[:, 1, 0] - m[:, 0, 1], m[:, 0, 2] + m[:, 2, 0], m[:, 1, 2] + m[:, 2, 1],
                  1 - m[:, 0, 0] - m[:, 1, 1] + m[:, 2, 2]], -1),
    ], axis=1)  # [N, 4 candidates, 4]
    best = np.argmax(np.stack([1 + tr, 1 + m[:, 0, 0] - m[:, 1, 1] - m[:, 2, 2],
                               1 - m[:, 0, 0] + m[:, 1, 1] - m[:, 2, 2],
                               1 - m[:, 0, 0] - m[:, 1, 1] + m[:, 2, 2]], -1), axis=1)
    q = cands[np.arange(len(m)), best]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q


SH_C1 = 0.4886025119029199
SH_C2 = (1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
         0.5462742152960396)
SH_C3 = (-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
         -0.4570457994644658, 1.445305721320277, -0.5900435899266435)


def sh_basis_3dgs(d: np.ndarray, k: int = 16) -> np.ndarray:
    """The INRIA 3DGS real SH basis (signs folded in) at unit directions ``[M, 3]`` -> ``[M, k]``.
    numpy mirror of GLSL ``splat_sh_basis`` (shaders/lib/splat.glsl)."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    xx, yy, zz = x * x, y * y, z * z
    cols = [np.full_like(x, SH_C0), -SH_C1 * y, SH_C1 * z, -SH_C1 * x,
            SH_C2[0] * x * y, SH_C2[1] * y * z, SH_C2[2] * (2 * zz - xx - yy), SH_C2[3] * x * z,
            SH_C2[4] * (xx - yy),
            SH_C3[0] * y * (3 * xx - yy), SH_C3[1] * x * y * z, SH_C3[2] * y * (4 * zz - xx - yy),
            SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy), SH_C3[4] * x * (4 * zz - xx - yy),
            SH_C3[5] * z * (xx - yy), SH_C3[6] * x * (xx - 3 * yy)]
    return np.stack(cols[:k], axis=-1)


def sh_rotation(rotation: np.ndarray, k: int) -> np.ndarray:
    """``[k, k]`` matrix D with sh_world = D @ sh_object for a rotation R (object -> world): the
    function f(R^-1 d) expressed in the basis. Fitted by least squares on 64 directions, which
    is exact (to float precision) because rotations map each band onto itself."""
    i = np.arange(64) + 0.5
    phi = np.arccos(1 - 2 * i / 64)
    theta = np.pi * (1 + 5 ** 0.5) * i
    d = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], -1)
    y_world = sh_basis_3dgs(d, k)
    y_object = sh_basis_3dgs(d @ np.asarray(rotation, np.float64), k)  # rows: R^T d
    return np.linalg.lstsq(y_world, y_object, rcond=None)[0]


def transform_splats(splats: Splats, matrix: np.ndarray) -> Splats:
    """Apply a 4x4 affine ``matrix`` (row-major, column vectors): means, covariances (A Sigma A^T,
    re-factored into R S), normals (inverse transpose) and SH (rotated by the polar rotation)."""
    m = np.asarray(matrix, np.float64)
    a, t = m[:3, :3], m[:3, 3]
    if len(splats) == 0:
        return splats
    means = splats.means.astype(np.float64) @ a.T + t
    cov = a @ splats.covariances() @ a.T
    vals, vecs = np.linalg.eigh(cov)
    vecs = vecs * np.where(np.linalg.det(vecs) < 0, -1.0, 1.0)[:, None, None]
    quats = matrix_to_quat(vecs)
    scales = np.sqrt(np.maximum(vals, 1e-30))
    inv_t = np.linalg.inv(a).T
    nrm = splats.normals.astype(np.float64) @ inv_t.T
    length = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.where(length > 0, nrm / np.maximum(length, 1e-30), 0.0)
    u, _, vt = np.linalg.svd(a)
    rot = u @ vt
    if np.linalg.det(rot) < 0:
        rot = -rot  # a reflection: SH get the rotation part only
    k = splats.sh.shape[1]
    d = sh_rotation(rot, k)
    sh = np.einsum("ij,njc->nic", d, splats.sh.astype(np.float64))
    return replace(splats, means=means.astype(np.float32), scales=scales.astype(np.float32),
                   rotations=quats.astype(np.float32), normals=nrm.astype(np.float32),
                   sh=sh.astype(np.float32))
