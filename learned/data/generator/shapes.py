"""The mesh files the generator's scenes draw from, written once into the dataset's ``_meshes``
cache: the random scenes' trimesh primitives (:func:`_mesh_files`), and the concave shapes, the
blocks kind's unit shapes and the textured glTF models of the visibility scene kinds (:func:`_shape_files`), with where a sphere
rests inside each concave shape (:func:`_nested_spot`)."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import trimesh

from .config import GLTF_MODELS


def _mesh_files(cache: Path, rank: int = 0) -> dict[str, Path]:
    cache.mkdir(parents=True, exist_ok=True)
    makers = {"torus": lambda: trimesh.creation.torus(0.6, 0.25, 48, 24),
              "box": lambda: trimesh.creation.box((0.9, 0.9, 0.9)),
              "capsule": lambda: trimesh.creation.capsule(0.8, 0.35, count=(24, 24))}
    out = {}
    for name, make in makers.items():
        p = cache / f"{name}.obj"
        if not p.is_file():
            tmp = cache / f"{name}.tmp{rank}.obj"  # one per rank: ranks may race here
            make().export(tmp)
            os.replace(tmp, p)
        out[name] = p
    return out


def _cached_file(cache: Path, name: str, make, rank: int) -> Path:
    """``cache/name``, written once by ``make(path)`` (through a per-rank temporary file)."""
    p = cache / name
    if not p.is_file():
        stem, dot, suffix = name.rpartition(".")
        tmp = cache / f"{stem}.tmp{rank}.{suffix}"  # one per rank: ranks may race here
        make(tmp)
        os.replace(tmp, p)
    return p


# concave shapes, in local coordinates: y up, resting on y = 0, about the y axis
_BOWL_R, _BOWL_T = 0.6, 0.08  # outer radius, wall thickness
_BOX_W, _BOX_H, _BOX_T = 1.1, 0.4, 0.06  # open box: width, wall height, wall/base thickness
_CORNER_L, _CORNER_H, _CORNER_T = 1.3, 0.9, 0.06  # corner: wall length, height, thickness
_RING_M, _RING_T = 0.5, 0.18  # torus lying flat: major radius, tube radius
_Y_UP = trimesh.transformations.rotation_matrix(-math.pi / 2, [1, 0, 0])  # +Z -> +Y


def _bowl() -> trimesh.Trimesh:
    """A hemispherical shell (outer radius _BOWL_R, open at the top), closed: revolved profile."""
    r, ri = _BOWL_R, _BOWL_R - _BOWL_T
    a = np.linspace(0.0, math.pi / 2, 24)
    outer = np.stack([r * np.sin(a), r - r * np.cos(a)], -1)  # from the bottom pole to the rim
    inner = np.stack([ri * np.sin(a), r - ri * np.cos(a)], -1)[::-1]  # rim back to the bottom
    profile = np.concatenate([outer, inner])
    m = trimesh.creation.revolve(profile, sections=48)
    m.apply_transform(_Y_UP)
    return m


def _boxes(parts) -> trimesh.Trimesh:
    """Closed boxes ``(extents, centre)`` side by side (each watertight; none overlaps)."""
    return trimesh.util.concatenate([trimesh.creation.box(e, trimesh.transformations
                                                          .translation_matrix(c))
                                     for e, c in parts])


def _open_box() -> trimesh.Trimesh:
    w, h, t = _BOX_W, _BOX_H, _BOX_T
    y = t + (h - t) / 2  # walls stand on the base
    inner = w - 2 * t
    return _boxes([((w, t, w), (0, t / 2, 0)),
                   ((w, h - t, t), (0, y, (w - t) / 2)), ((w, h - t, t), (0, y, -(w - t) / 2)),
                   ((t, h - t, inner), ((w - t) / 2, y, 0)), ((t, h - t, inner), (-(w - t) / 2, y, 0))])


def _corner() -> trimesh.Trimesh:
    """Two walls meeting at a right angle (an L), standing on the floor: along x at the back
    (z = -L/2 .. -L/2 + t) and along z on the left (x = -L/2 .. -L/2 + t); open towards +x+z."""
    L, h, t = _CORNER_L, _CORNER_H, _CORNER_T
    return _boxes([((L, h, t), (0, h / 2, -(L - t) / 2)),
                   ((t, h, L - t), (-(L - t) / 2, h / 2, t / 2))])


def _ring() -> trimesh.Trimesh:
    m = trimesh.creation.torus(_RING_M, _RING_T, 48, 24)
    m.apply_transform(_Y_UP)
    m.apply_translation([0, _RING_T, 0])
    return m


_CONCAVE_MAKERS = {"bowl": _bowl, "open_box": _open_box, "corner": _corner, "ring": _ring}


# the "blocks" kind's unit shapes (BLOCK_SHAPES), scaled per body by the scene (non-uniformly:
# a cube, a slab, a post or a thin standing panel from the one box); shaded smooth with the
# creases split (flat box faces, round tube walls)
def _block_box() -> trimesh.Trimesh:
    return trimesh.creation.box((1.0, 1.0, 1.0)).smooth_shaded


def _block_tube() -> trimesh.Trimesh:
    """An open pipe along z: outer radius 0.5, wall 0.08, length 1 (one looks into it)."""
    return trimesh.creation.annulus(0.42, 0.5, 1.0, sections=48).smooth_shaded


def _block_arch() -> trimesh.Trimesh:
    """Two legs and a lintel (1 wide, 1 tall, 0.5 deep): a tunnel half its width."""
    return _boxes([((0.25, 0.75, 0.5), (-0.375, 0.375, 0.0)),
                   ((0.25, 0.75, 0.5), (0.375, 0.375, 0.0)),
                   ((1.0, 0.25, 0.5), (0.0, 0.875, 0.0))]).smooth_shaded


_BLOCK_MAKERS = {"box": _block_box, "tube": _block_tube, "arch": _block_arch}


def _nested_spot(shape: str, rng) -> tuple[np.ndarray, float]:
    """A sphere resting inside concave ``shape`` (local coordinates): ``(centre, radius)``. In the
    bowl: touching its inner bottom; in the box: on its base; in the corner: touching both walls
    and the floor; in the ring's hole: on the floor, touching the tube all round."""
    if shape == "bowl":
        ri = _BOWL_R - _BOWL_T
        rs = float(rng.uniform(0.3, 0.7)) * ri
        return np.array([0.0, _BOWL_R - ri + rs, 0.0]), rs
    if shape == "open_box":
        rs = float(rng.uniform(0.12, 0.25))
        room = _BOX_W / 2 - _BOX_T - rs
        x, z = (float(v) for v in rng.uniform(-room, room, 2))
        return np.array([x, _BOX_T + rs, z]), rs
    if shape == "corner":
        rs = float(rng.uniform(0.15, 0.35))
        c = -_CORNER_L / 2 + _CORNER_T + rs
        return np.array([c, rs, c]), rs
    if shape == "ring":  # |(M, T) - (0, rs)| = rs + T  <=>  rs = M^2 / 4T
        rs = _RING_M ** 2 / (4 * _RING_T)
        return np.array([0.0, rs, 0.0]), rs
    raise ValueError(shape)


def _revolved(profile: np.ndarray, sections: int):
    """A surface of revolution about y with a texture seam (the first column repeated with u = 1):
    positions, normals (from the profile's tangent), uvs and faces. ``profile`` ``[K, 2]`` (radius,
    height) from the bottom's axis point to the top's."""
    k = len(profile)
    ang = np.linspace(0.0, 2 * math.pi, sections + 1)
    r, y = profile[:, 0], profile[:, 1]
    d = np.gradient(profile, axis=0)
    nr, ny = d[:, 1], -d[:, 0]  # the tangent turned outwards
    nn = np.hypot(nr, ny)
    nr, ny = nr / nn, ny / nn
    nr[0], ny[0], nr[-1], ny[-1] = 0.0, -1.0, 0.0, 1.0  # the poles
    c, s = np.cos(ang)[None, :], np.sin(ang)[None, :]
    pos = np.stack([r[:, None] * c, np.repeat(y[:, None], sections + 1, 1), r[:, None] * s], -1)
    nrm = np.stack([nr[:, None] * c, np.repeat(ny[:, None], sections + 1, 1), nr[:, None] * s], -1)
    uv = np.stack(np.meshgrid(ang / (2 * math.pi), np.linspace(0.0, 1.0, k)), -1)
    idx = np.arange(k * (sections + 1)).reshape(k, sections + 1)
    a, b, cc, dd = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    faces = np.concatenate([np.stack([a, cc, b], -1).reshape(-1, 3),
                            np.stack([b, cc, dd], -1).reshape(-1, 3)])
    pos = pos.reshape(-1, 3)
    tri = pos[faces]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=-1)
    faces = faces[area > 1e-12]  # the poles' fans are half degenerate
    return pos, nrm.reshape(-1, 3), uv.reshape(-1, 2), faces


def _texture_images(kind: str):
    """The glTF models' fixed textures (PIL RGB images, 64 x 64): base colour and metallic-
    roughness (G roughness, B metallic)."""
    from PIL import Image

    yy, xx = np.mgrid[0:64, 0:64]
    if kind == "vase":  # bands and a checker of terracotta and cream; glossy cream bands
        band = (yy // 8) % 2
        check = ((yy // 8) + (xx // 8)) % 2
        c0, c1 = np.array([200, 90, 50]), np.array([235, 225, 200])
        base = np.where((band * check)[..., None] > 0, c1, c0)
        rough = np.where(band > 0, 60, 200)
        metal = np.zeros_like(rough)
    else:  # crate: planks with dark gaps, one metal band
        plank = (yy // 16) % 2
        gap = (yy % 16) < 2
        base = np.where(plank[..., None] > 0, np.array([150, 100, 55]), np.array([120, 80, 45]))
        base = np.where(gap[..., None], np.array([30, 20, 10]), base)
        band = (xx >= 28) & (xx < 36)
        base = np.where(band[..., None], np.array([180, 180, 185]), base)
        rough = np.where(band, 90, 230)
        metal = np.where(band, 255, 0)
    mr = np.stack([np.zeros_like(rough), rough, metal], -1)
    return (Image.fromarray(base.astype(np.uint8), "RGB"),
            Image.fromarray(mr.astype(np.uint8), "RGB"))


def _gltf_model(kind: str, path: Path) -> None:
    """Write textured glTF model ``kind`` (GLTF_MODELS; y up, resting on y = 0; double-sided, as
    the reference traces it) to ``path`` (.glb)."""
    from trimesh.visual import TextureVisuals
    from trimesh.visual.material import PBRMaterial

    if kind == "vase":  # a closed vase: foot, belly, neck (concave), lip; ~0.9 tall
        prof = np.array([[0.0, 0.0], [0.22, 0.0], [0.3, 0.05], [0.38, 0.2], [0.41, 0.35],
                         [0.36, 0.52], [0.22, 0.66], [0.16, 0.74], [0.19, 0.84], [0.22, 0.9],
                         [0.12, 0.9], [0.0, 0.9]])
        pos, nrm, uv, faces = _revolved(prof, 48)
    else:  # a crate: a box 0.8 x 0.6 x 0.6 whose faces each map the whole texture
        box = trimesh.creation.box((0.8, 0.6, 0.6))
        box.apply_translation([0, 0.3, 0])
        tri = box.vertices[box.faces]  # unshared vertices: one normal and uv frame per face
        pos = tri.reshape(-1, 3)
        nrm = np.repeat(box.face_normals, 3, axis=0)
        uv = np.zeros((len(pos), 2))
        for f in range(len(box.faces)):
            n = np.abs(box.face_normals[f])
            ax = [i for i in range(3) if i != int(np.argmax(n))]
            p = tri[f][:, ax]
            lo, hi = box.bounds[0][ax], box.bounds[1][ax]
            uv[3 * f:3 * f + 3] = (p - lo) / (hi - lo)
        faces = np.arange(len(pos)).reshape(-1, 3)
    base, mr = _texture_images(kind)
    material = PBRMaterial(name=kind, baseColorTexture=base, metallicRoughnessTexture=mr,
                           baseColorFactor=[255, 255, 255, 255], metallicFactor=1.0,
                           roughnessFactor=1.0, doubleSided=True)
    mesh = trimesh.Trimesh(pos, faces, vertex_normals=nrm, process=False,
                           visual=TextureVisuals(uv=uv, material=material))
    mesh.export(path)


def _shape_files(cache: Path, rank: int = 0) -> dict[str, Path]:
    """The concave shapes (``concave_<name>.obj``, OBJ: double-sided), the blocks kind's unit
    shapes (``block_<name>.obj``, keys ``block_<name>``) and the textured glTF models
    (``gltf_<name>.glb``) of the new scene kinds, written once into the mesh cache."""
    cache.mkdir(parents=True, exist_ok=True)
    out = {}
    for name, make in _BLOCK_MAKERS.items():
        out[f"block_{name}"] = _cached_file(cache, f"block_{name}.obj",
                                            lambda p, make=make: make().export(p), rank)
    for name, make in _CONCAVE_MAKERS.items():
        out[name] = _cached_file(cache, f"concave_{name}.obj",
                                 lambda p, make=make: make().export(p), rank)
    for name in GLTF_MODELS:
        out[name] = _cached_file(cache, f"gltf_{name}.glb",
                                 lambda p, name=name: _gltf_model(name, p), rank)
    return out
