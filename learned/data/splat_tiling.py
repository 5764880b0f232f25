"""A mesh scene turned into a Gaussian-splat cloud that tiles every surface with its true
material: what a perfect capture and material decomposition of the scene would give (per splat
albedo, roughness, metallic and the surface normal), for drawing a scene through the viewer's
splat G-buffer path instead of its rasteriser (:func:`scene_splats`).

Every splat is a flat Gaussian lying in its surface (the third axis, along the normal, is
:data:`THIN` of the in-plane one), sized from the camera: a surface at depth ``d`` facing it gets
one splat per ``spacing^2`` px^2 (a spacing of ``spacing * d * 2 tan(fov_y / 2) / H`` in world
units; depths below :data:`NEAR` count as :data:`NEAR`), so a far surface gets larger splats and
the count follows the image, not the scene's size.

* **Spheres** (and a ``material_grid``'s balls) - a Fibonacci lattice on the exact sphere, one
  cell per spacing^2 at its nearest point's depth; radial normals.
* **Triangles** (meshes, and planes, whose two triangles the rasteriser draws): each triangle
  is split at its edges' midpoints, recursively, until a piece covers at most ``spacing^2``
  px^2 as the camera sees it and no edge of it is longer than :data:`WORLD_CAP` spacings at its
  nearest corner's depth (area-weighted: a large triangle gets proportionally many splats, a
  piece far away or seen edge-on fewer), and every piece becomes one splat at its centroid whose
  in-plane covariance is the piece's own (``(1/12) sum_i (v_i - m)(v_i - m)^T``, a uniform
  triangle's) times :data:`SIGMA_SCALE` squared, oriented to the triangle's normal. Its normal
  is the rasteriser's shading normal (the vertex normals interpolated at the centroid), its
  material the mesh's factors times its textures there (``base_color``, ``metallic_roughness``,
  bilinear, the map's texture coordinate set, ``KHR_texture_transform`` and wrap modes) and
  vertex colours. Normal maps are not applied (the splat keeps the interpolated normal).
* **Planes** are bounded to what the camera sees: pieces wholly outside the view frustum
  (widened by :data:`MARGIN` pixels) or behind the camera are dropped while splitting, so the
  generator's 12 x 12 m floors cost what their visible part costs. Spheres and meshes are tiled
  whole (their unseen sides still cast the shadow maps' shadows).

The splat G-buffer has no ``specular`` channel: every splat is a dielectric of Filament's
``specular`` 0.5 (``shaders/passes/splat_resolve.frag``), whatever the material's.

Imports: :mod:`viewer.geometry`, :mod:`viewer.splats`, :mod:`viewer.scene`; no GL.
"""
from __future__ import annotations

import math

import numpy as np

from viewer.geometry.loaders import load_mesh
from viewer.scene.description import Scene
from viewer.splats.data import Splats, concat, make_splats, matrix_to_quat

SPACING = 1.0  # px between neighbouring splats on a surface facing the camera
SIGMA_SCALE = 1.6  # splat sigma / the moment-matched sigma of its piece: neighbours overlap
# enough that the interior is covered (alpha -> 1) while a silhouette blurs by < 1 px
THIN = 0.02  # the normal axis' sigma / the largest in-plane one
OPACITY = 0.98
WORLD_CAP = 8.0  # a piece's longest edge / the spacing at its depth (a floor seen at a grazing
# angle is foreshortened about that much at the generator's camera heights)
NEAR = 0.05  # m: the depth below which the spacing stops shrinking
MARGIN = 4.0  # px beyond the image that a plane is still tiled
MAX_SPLATS = 1_000_000  # per scene: beyond this, one line instead of an exhausted machine
_MAX_LEVELS = 24


class _View:
    """The camera as the tiler needs it: depths, a pixel's world size and the frustum test."""

    def __init__(self, camera, spacing: float):
        self.pos = np.asarray(camera.position, np.float64)
        f = np.asarray(camera.target, np.float64) - self.pos
        f /= np.linalg.norm(f)
        r = np.cross(f, np.asarray(camera.up, np.float64))
        r /= np.linalg.norm(r)
        self.basis = np.stack([r, np.cross(r, f), f])  # rows: right, up, forward
        self.tx, self.ty = camera.tan_half_fov()
        self.width, self.height = camera.size
        self.spacing = float(spacing)

    def local(self, p: np.ndarray) -> np.ndarray:
        """``[..., 3]`` world points -> (right, up, depth) camera coordinates."""
        return (p - self.pos) @ self.basis.T

    def step(self, depth: np.ndarray) -> np.ndarray:
        """The world spacing of splats at ``depth``."""
        return self.spacing * np.maximum(depth, NEAR) * 2.0 * self.ty / self.height

    def small(self, corners: np.ndarray) -> np.ndarray:
        """``[T]`` pieces (``[T, 3, 3]`` world corners) that one splat may cover: seen from the
        camera at most ``spacing^2`` px^2, and no edge longer than WORLD_CAP steps at the
        nearest corner's depth."""
        c = self.local(corners)
        d = np.maximum(c[..., 2], NEAR)
        px = c[..., :2] / d[..., None] * (self.height / (2.0 * self.ty))  # [T, 3, 2] pixels
        e1, e2 = px[:, 1] - px[:, 0], px[:, 2] - px[:, 0]
        area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        edge = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=-1).max(axis=1)
        return (area <= self.spacing ** 2) & (edge <= WORLD_CAP * self.step(d.min(axis=1)))

    def outside(self, corners: np.ndarray) -> np.ndarray:
        """``[T]`` pieces (``[T, 3, 3]`` world corners) wholly beyond one frustum side (widened
        by MARGIN px) or behind the camera's NEAR plane."""
        c = self.local(corners)
        x, y, d = c[..., 0], c[..., 1], c[..., 2]
        wx = self.tx * (1.0 + 2.0 * MARGIN / self.width)
        wy = self.ty * (1.0 + 2.0 * MARGIN / self.height)
        sides = (d < NEAR, x > wx * d, x < -wx * d, y > wy * d, y < -wy * d)
        return np.any([s.all(axis=1) for s in sides], axis=0)


# ---- pieces of triangles ---------------------------------------------------------------------

_MIDPOINTS = np.array([[[1, 0, 0], [.5, .5, 0], [.5, 0, .5]],
                       [[.5, .5, 0], [0, 1, 0], [0, .5, .5]],
                       [[.5, 0, .5], [0, .5, .5], [0, 0, 1]],
                       [[.5, .5, 0], [0, .5, .5], [.5, 0, .5]]])  # 4 children x corners x parent


def split_triangles(tris: np.ndarray, view: _View, cull: bool
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The pieces of ``tris`` (``[T, 3, 3]`` world corners) small enough for one splat each
    (module doc): ``(parent index [N], corners' barycentric coordinates in it [N, 3, 3])``;
    ``cull``: drop pieces outside the view."""
    parent = np.arange(len(tris))
    bary = np.broadcast_to(np.eye(3), (len(tris), 3, 3)).copy()
    done_p, done_b = [], []
    for _ in range(_MAX_LEVELS):
        if not len(parent):
            break
        corners = np.einsum("tij,tjk->tik", bary, tris[parent])
        small = view.small(corners)
        keep = ~view.outside(corners) if cull else np.ones(len(parent), bool)
        done_p.append(parent[small & keep])
        done_b.append(bary[small & keep])
        split = ~small & keep
        parent, bary = parent[split], bary[split]
        if 4 * len(parent) + sum(len(p) for p in done_p) > MAX_SPLATS:
            raise ValueError(f"more than {MAX_SPLATS} splats: the surfaces come too close to "
                             f"the camera for a spacing of {view.spacing} px")
        bary = np.einsum("cij,tjk->tcik", _MIDPOINTS, bary).reshape(-1, 3, 3)
        parent = np.repeat(parent, 4)
    else:
        if len(parent):
            raise ValueError(f"pieces still too large after {_MAX_LEVELS} splits")
    if not done_p:
        return np.zeros(0, np.int64), np.zeros((0, 3, 3))
    return np.concatenate(done_p), np.concatenate(done_b)


def piece_frames(corners: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rotations [N, 3, 3], scales [N, 3])`` of flat Gaussians with each piece's in-plane
    covariance (``corners`` ``[N, 3, 3]``) times SIGMA_SCALE^2, third axis along ``normals``."""
    m = corners.mean(axis=1, keepdims=True)
    d = corners - m
    cov = np.einsum("nij,nik->njk", d, d) / 12.0
    # project out the normal (the piece is flat; rounding leaves a sliver of it)
    proj = np.eye(3) - normals[:, :, None] * normals[:, None, :]
    vals, vecs = np.linalg.eigh(proj @ cov @ proj)  # ascending: ~0 (the normal), minor, major
    major = vecs[:, :, 2] - np.sum(vecs[:, :, 2] * normals, -1, keepdims=True) * normals
    major /= np.linalg.norm(major, axis=1, keepdims=True)
    minor = np.cross(normals, major)
    sig = SIGMA_SCALE * np.sqrt(np.maximum(vals[:, 1:], 0.0))  # minor, major
    sig_major = np.maximum(sig[:, 1], 1e-9)
    sig_minor = np.maximum(sig[:, 0], 1e-3 * sig_major)
    rot = np.stack([major, minor, normals], axis=-1)  # columns: right-handed (major x minor = n)
    return rot, np.stack([sig_major, sig_minor, THIN * sig_major], axis=-1)


# ---- textures ----------------------------------------------------------------------------------

def _wrap(t: np.ndarray, mode: str) -> np.ndarray:
    if mode == "clamp":
        return np.clip(t, 0.0, 1.0)
    if mode == "mirror":
        f = np.mod(t, 2.0)
        return np.where(f > 1.0, 2.0 - f, f)
    return np.mod(t, 1.0)


def sample_texture(image: np.ndarray, uv: np.ndarray, sampling=None) -> np.ndarray:
    """``[N, C]`` bilinear lookups of ``image`` ``[H, W, C]`` (row 0 at the top, glTF UVs) at
    ``uv`` ``[N, 2]``, after the sampling's ``KHR_texture_transform`` and wrap modes."""
    uv = np.asarray(uv, np.float64)
    if sampling is not None:
        c, s = math.cos(sampling.rotation), math.sin(sampling.rotation)
        su, sv = sampling.scale
        u, v = uv[:, 0] * su, uv[:, 1] * sv
        uv = np.stack([c * u + s * v, -s * u + c * v], -1) + np.asarray(sampling.offset)
        uv = np.stack([_wrap(uv[:, 0], sampling.wrap[0]), _wrap(uv[:, 1], sampling.wrap[1])], -1)
    else:
        uv = np.mod(uv, 1.0)
    img = image if image.ndim == 3 else image[..., None]
    h, w = img.shape[:2]
    x, y = uv[:, 0] * w - 0.5, uv[:, 1] * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0, y0 = x0.astype(int), y0.astype(int)

    def at(xi, yi):
        return img[np.mod(yi, h), np.mod(xi, w)].astype(np.float64)

    return ((at(x0, y0) * (1 - fx) + at(x0 + 1, y0) * fx) * (1 - fy)
            + (at(x0, y0 + 1) * (1 - fx) + at(x0 + 1, y0 + 1) * fx) * fy)


def _uvs(mesh, key: str):
    sampling = mesh.sampling.get(key)
    uvs = mesh.uvs if sampling is None or sampling.texcoord == 0 else mesh.uvs1
    return uvs, sampling


def mesh_materials(mesh, tri: np.ndarray, bary: np.ndarray) -> dict[str, np.ndarray]:
    """Albedo ``[N, 3]``, roughness and metallic ``[N]`` of ``mesh`` at the points ``bary``
    (barycentric, ``[N, 3]``) of its triangles ``tri`` (``[N, 3]`` vertex indices)."""
    mat, n = mesh.material, len(tri)
    albedo = np.tile(np.asarray(mat.albedo, np.float64), (n, 1))
    rough, metal = np.full(n, float(mat.roughness)), np.full(n, float(mat.metallic))

    def at_points(values):
        return np.einsum("ni,nic->nc", bary, values[tri].astype(np.float64))

    for key in ("base_color", "metallic_roughness"):
        image = mesh.textures.get(key)
        uvs, sampling = _uvs(mesh, key)
        if image is None or uvs is None:
            continue
        texel = sample_texture(image, at_points(uvs), sampling)
        if key == "base_color":
            albedo *= texel[:, :3]
        else:
            rough *= texel[:, 1]
            metal *= texel[:, 2]
    if mesh.colors is not None:
        albedo *= at_points(mesh.colors)[:, :3]
    return {"albedo": np.clip(albedo, 0, 1), "roughness": np.clip(rough, 0, 1),
            "metallic": np.clip(metal, 0, 1)}


# ---- objects ------------------------------------------------------------------------------------

def _cloud(means, rot, scales, normals, albedo, roughness, metallic) -> Splats:
    n = len(means)
    return make_splats(means, scales, matrix_to_quat(rot), np.full(n, OPACITY), albedo=albedo,
                       roughness=roughness, metallic=metallic, normals=normals)


def mesh_splats(mesh, view: _View, cull: bool = False) -> Splats:
    """The splats tiling one :class:`~viewer.geometry.mesh.Mesh` (module doc)."""
    pos = mesh.positions.astype(np.float64)
    idx = mesh.indices.astype(np.int64)
    tris = pos[idx]
    face = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    area2 = np.linalg.norm(face, axis=1)
    ok = area2 > 1e-12 * max(float(area2.max(initial=0.0)), 1e-30)  # no degenerate triangles
    idx, tris, face = idx[ok], tris[ok], face[ok] / area2[ok, None]
    parent, bary = split_triangles(tris, view, cull)
    corners = np.einsum("nij,njk->nik", bary, tris[parent])
    centre = bary.mean(axis=1)  # the piece's centroid in its triangle's barycentrics
    shading = np.einsum("ni,nic->nc", centre, mesh.normals[idx[parent]].astype(np.float64))
    length = np.linalg.norm(shading, axis=1, keepdims=True)
    shading = np.where(length > 1e-9, shading / np.maximum(length, 1e-12), face[parent])
    rot, scales = piece_frames(corners, face[parent])
    mats = mesh_materials(mesh, idx[parent], centre)
    return _cloud(corners.mean(axis=1), rot, scales, shading, **mats)


def sphere_splats(center, radius: float, material, view: _View) -> Splats:
    """A Fibonacci lattice of flat splats on the exact sphere (module doc)."""
    c = np.asarray(center, np.float64)
    step = float(view.step(view.local(c)[2] - radius))
    n = max(16, math.ceil(4.0 * math.pi * radius ** 2 / step ** 2))
    if n > MAX_SPLATS:
        raise ValueError(f"a sphere of radius {radius} needs {n} splats (> {MAX_SPLATS})")
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = np.pi * (1 + 5 ** 0.5) * i
    nrm = np.stack([np.cos(theta) * np.sin(phi), np.cos(phi), np.sin(theta) * np.sin(phi)], -1)
    helper = np.where(np.abs(nrm[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(helper, nrm)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    rot = np.stack([t1, np.cross(nrm, t1), nrm], axis=-1)
    cell = radius * math.sqrt(4.0 * math.pi / n)  # a lattice cell's side
    sig = SIGMA_SCALE * cell / math.sqrt(12.0)  # a square cell's moment-matched sigma, scaled
    scales = np.tile([sig, sig, THIN * sig], (n, 1))
    return _cloud(c + radius * nrm, rot, scales, nrm,
                  np.tile(np.asarray(material.albedo, np.float64), (n, 1)),
                  np.full(n, float(material.roughness)), np.full(n, float(material.metallic)))


def object_meshes(obj) -> list:
    """The triangle meshes the rasteriser draws for a plane or mesh object."""
    from viewer.geometry import primitives

    if obj.type == "plane":
        return [primitives.plane(center=obj.center, size=obj.size, normal=obj.normal,
                                 material=obj.material)]
    transform = None if obj.transform is None else np.asarray(obj.transform, np.float64)
    return list(load_mesh(obj.path, transform=transform, material_override=obj.material,
                          variant=obj.variant))


def scene_splats(scene: Scene, spacing: float = SPACING) -> Splats:
    """One cloud tiling every sphere (material grids: their balls), plane and mesh of ``scene``
    as its camera sees them, each
    splat with its surface's material and normal (module doc); ``spacing`` in pixels. Other
    object types are a ``ValueError`` (splats and image stacks are no surfaces to tile)."""
    view = _View(scene.camera, spacing)
    parts = []
    for obj in scene.objects:
        if obj.type == "sphere":
            parts.append(sphere_splats(obj.center, obj.radius, obj.material, view))
        elif obj.type == "material_grid":  # spheres: each ball's centre is its bounds' centre
            from viewer.geometry import primitives

            for ball in primitives.material_ball_grid(
                    rows=obj.rows, cols=obj.cols, spacing=obj.spacing, radius=obj.radius,
                    albedo=obj.material.albedo, center=obj.center, segments=8, rings=4):
                mid = 0.5 * (ball.positions.min(axis=0) + ball.positions.max(axis=0))
                parts.append(sphere_splats(mid, obj.radius, ball.material, view))
        elif obj.type in ("plane", "mesh"):
            parts += [mesh_splats(m, view, cull=obj.type == "plane") for m in object_meshes(obj)]
        else:
            raise ValueError(f"a {obj.type} object has no surfaces to tile with splats")
    out = concat([p for p in parts if len(p)] or parts)
    if len(out) > MAX_SPLATS:
        raise ValueError(f"{len(out)} splats (> {MAX_SPLATS}): raise the spacing "
                         f"({spacing} px)")
    return out
