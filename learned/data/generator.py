"""Synthetic datasets in the FFHQ256-PBR layout, rendered by the workbench.

    relight-style use:  generate("data/quick", GeneratorConfig(count=24, size=64), progress=True)

Every sample is a random scene seen from a camera at the origin looking down -Z (so camera space is
world space, as the layout wants): 1-3 spheres and meshes (torus, box, capsule made with trimesh)
with random materials, usually a floor plane, under a procedural sky (random sun) or studio, or
one of ``env_paths``, at a random intensity and rotation (baked into the written ``env.exr``).
The target ``rgb.exr`` is the Monte-Carlo reference ``ggx_mc`` (``samples`` per pixel, MIS) with
the G-buffer AO, SSAO and one-bounce indirect light when the renderer has them (see
:func:`target_settings`) - so the shadow stage has occlusion to learn; otherwise ``ggx_split_sum``.
``rgb_unoccluded.exr`` is the same render without any occlusion (no AO, SSAO or indirect light:
for convex objects the exact single-bounce integral): the unshadowed image I_unshadow of thesis
eq. 4.3, the teacher's target in phase 1 (issue 14: trained on ``rgb``, the teacher learned the
training set's mean occlusion as part of the BRDF, and every distilled student inherited it).

Image G-buffers as geometry: a ``gbuffer_fraction`` of the samples (drawn per sample from its own
stream ``default_rng([seed, i, 1])``, so datasets made without them are unchanged) takes its
geometry from an image-space G-buffer instead: one of ``gbuffers`` (FFHQ256-PBR folders or
12-channel ShadingFusion stack EXRs, resampled to ``size`` by nearest neighbour) or, when none is
given, the G-buffer of a freshly rendered random scene. Its materials are perturbed per pixel
(:func:`perturb_materials`: smooth random fields on albedo, roughness, metallic, specular and AO -
spatially varying materials that the primitives cannot produce), it is written as an FFHQ256-PBR
folder and rendered as a ``gbuffer`` object with the same target settings.

Targets from truth (issue 14): with ``targets = "reference"`` the target ``rgb.exr`` is
path-traced by ``relight reference`` (Mitsuba 3, our BSDF, visibility and inter-reflection;
pixel-centre rays, so pixels align with the G-buffer; ``reference_depth``, ``reference_spp``),
with its per-pixel standard error in ``rgb_stderr.exr``; the G-buffer inputs and
``rgb_unoccluded.exr`` come from one rasteriser render as before, and ``meta.json``'s ``target``
records the source (``rasteriser`` | ``reference``, with spp, depth, seed, backend, seconds).
Material AO is set to 1 there (the path tracer computes visibility itself). ``learned`` does not
import ``relight``: the caller passes the tracer (``relight.commands.reference_tracer()``).
``scene_kinds`` adds scenes where visibility matters (:data:`SCENE_KINDS`: a sphere resting on a
floor, two touching spheres on a floor, clusters of 3-6 spheres and meshes touching or close to
each other, concave meshes (a bowl, an open box, a room corner of two walls, a torus lying flat),
textured glTF models, a sphere nested inside a concave mesh, and a lone sphere as the convex
control), sample i of kind ``scene_kinds[i % len]``; the default ``("random",)`` leaves datasets
unchanged. Every object of these kinds rests on the floor: its lowest point, after its transform,
on the plane. The concave shapes (OBJ: double-sided, made of closed parts) and the glTF models
(``.glb``, base-colour and metallic-roughness textures, double-sided) are written once into the
dataset's ``_meshes`` cache; a glTF object keeps its file's material, so its textures go through
the rasteriser and the path tracer alike.

Environments: ``env_procedural`` (default sky, sky, studio) and the files ``env_paths`` (the real
HDRIs :data:`ENVIRONMENTS`, small very bright suns; repository-relative paths resolve against the
repository). :func:`held_out_config` turns a training configuration into an evaluation one that
shares no environment and no scene kind with it (default: esplanade alone, :data:`HELD_OUT_KINDS`;
the training truth of ``relight train --targets reference`` draws sky and park,
:data:`TRUTH_ENV_PATHS`, and :data:`TRUTH_KINDS`).

Degraded inputs: ``degrade`` > 0 writes G-buffer inputs that are wrong the way inverse rendering's
estimates are (:func:`degrade_inputs`: noisy normals, shading baked into albedo, biased
roughness; drawn from the sample's stream ``default_rng([seed, i, 2])``, the recipe in
``meta.json``'s ``degrade``), while ``rgb.exr`` and ``rgb_unoccluded.exr`` stay those of the true
scene (thesis ch. 4's setting). With ``shard=True`` every torchrun rank writes the samples i with
i % WORLD_SIZE == RANK and then waits for the others' (a file-system barrier).

Deterministic for a seed (sample i draws from ``default_rng([seed, i])``; its split is fixed by i),
resumable (a finished sample is a folder; one being written is ``<name>.tmp`` and is redone), and
shows a tqdm progress bar.
"""
from __future__ import annotations

import functools
import json
import math
import os
import shutil
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import trimesh
from tqdm import tqdm

from assets import ASSET_ROOT
from viewer.environment import EnvironmentSpec, load_environment, resample
from viewer.geometry.imagespace import load_ffhq_pbr, load_stack_exr
from viewer.geometry.loaders import load_mesh
from viewer.imageio import write_exr
from viewer.models import MODELS
from viewer.renderer import Renderer
from viewer.scene import scene_from_dict
from viewer.settings import RenderSettings

from .reader import STDERR_FILE, DatasetError

SPLIT_PATTERN = ("train",) * 8 + ("val", "test")  # sample i -> SPLIT_PATTERN[i % 10]
FORMAT = "relight-ffhq-pbr-synthetic/1"


@dataclass(frozen=True)
class GeneratorConfig:
    count: int = 24
    size: int = 64  # square images
    samples: int = 256  # Monte-Carlo samples per pixel of the target
    seed: int = 0
    env_width: int = 128
    env_paths: tuple[str, ...] = ()  # extra equirect HDR/EXR files to draw from
    meshes: bool = True
    gbuffer_fraction: float = 0.0  # share of samples whose geometry is an image G-buffer
    gbuffers: tuple[str, ...] = ()  # FFHQ256-PBR folders / 12-channel stack EXRs to draw from
    # sample i's scene: scene_kinds[i % len] (SCENE_KINDS; "random" = random_scene, as before)
    scene_kinds: tuple[str, ...] = ("random",)
    targets: str = "rasteriser"  # TARGETS: where rgb.exr comes from
    reference_spp: int = 256  # path-traced samples per pixel (targets = "reference")
    reference_depth: int = 4  # Mitsuba path depth (targets = "reference")
    # the procedural environments drawn from beside env_paths (repeats weight the draw; () = the
    # files alone, e.g. a held-out set of real HDRIs)
    env_procedural: tuple[str, ...] = ("sky", "sky", "studio")
    # degraded inputs (0 = off): the written G-buffer is wrong the way inverse-rendering estimates
    # are (noisy normals, shading baked into albedo, biased roughness) at this strength (<= 1);
    # the targets stay those of the true scene (degrade_inputs)
    degrade: float = 0.0


TARGETS = ("rasteriser", "reference")
# "convex": one sphere alone (truth = the unoccluded target: a control); "sphere_on_plane": a
# sphere resting on a floor (contact shadow); "touching_spheres": two spheres touching, resting on
# a floor (occlusion and inter-reflection between them); "cluster": 3-6 spheres and meshes
# resting on a floor, touching or close to each other; "concave": one concave mesh on a floor
# (CONCAVE_SHAPES: a bowl, an open box, a room corner of two walls, a torus lying flat: self-
# occlusion and inter-reflection); "gltf": 1-3 textured glTF models (GLTF_MODELS) and spheres on a
# floor (textures through both the rasteriser and the tracer); "nested": a concave mesh with a
# sphere resting inside it (in the bowl, the box, the corner, the torus's hole)
SCENE_KINDS = ("random", "convex", "sphere_on_plane", "touching_spheres", "cluster", "concave",
               "gltf", "nested")
# the kinds of `relight train --targets reference`: a third random scenes, the rest scenes where
# visibility and inter-reflection matter
TRUTH_KINDS = ("random", "sphere_on_plane", "cluster", "random", "touching_spheres", "concave",
               "random", "cluster", "gltf")
# kinds no training sample of TRUTH_KINDS sees (held_out_config): the convex control and the
# nested scenes (a sphere inside a concave mesh)
HELD_OUT_KINDS = ("nested", "convex")
CONCAVE_SHAPES = ("bowl", "open_box", "corner", "ring")
GLTF_MODELS = ("vase", "crate")
# the real HDRIs (assets/environments: small, very bright suns), repository-relative; the
# training truth sees sky and park, the held-out sets esplanade
ENVIRONMENTS = {name: f"assets/environments/{name}.exr" for name in ("sky", "park", "esplanade")}
TRUTH_ENV_PATHS = (ENVIRONMENTS["sky"], ENVIRONMENTS["park"])
HELD_OUT_ENV_PATHS = (ENVIRONMENTS["esplanade"],)
PROCEDURAL_ENVIRONMENTS = ("sky", "studio")


def split_of(index: int) -> str:
    return SPLIT_PATTERN[index % len(SPLIT_PATTERN)]


def target_settings(samples: int) -> dict:
    """Render settings of the targets: ggx_mc + AO + SSAO + indirect when available."""

    names = {f.name for f in RenderSettings.__dataclass_fields__.values()}
    if "ggx_mc" in MODELS:
        kw = {"model": "ggx_mc", "samples": int(samples), "sampling": "mis", "ao": True}
    else:  # pragma: no cover - before the Monte-Carlo model existed
        kw = {"model": "ggx_split_sum", "ao": True}
    for k in ("ssao", "indirect"):
        if k in names:
            kw[k] = True
    kw.update({"background": "environment", "tonemap": "none"})
    return kw


def unoccluded_settings(samples: int) -> dict:
    """Render settings of the unoccluded targets: :func:`target_settings` without AO, SSAO or
    indirect light."""
    kw = target_settings(samples) | {"ao": False}
    for k in ("ssao", "indirect"):
        if k in kw:
            kw[k] = False
    return kw


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
    """The concave shapes (``concave_<name>.obj``, OBJ: double-sided) and the textured glTF
    models (``gltf_<name>.glb``) of the new scene kinds, written once into the mesh cache."""
    cache.mkdir(parents=True, exist_ok=True)
    out = {}
    for name, make in _CONCAVE_MAKERS.items():
        out[name] = _cached_file(cache, f"concave_{name}.obj",
                                 lambda p, make=make: make().export(p), rank)
    for name in GLTF_MODELS:
        out[name] = _cached_file(cache, f"gltf_{name}.glb",
                                 lambda p, name=name: _gltf_model(name, p), rank)
    return out


def _material(rng) -> dict:
    metal = rng.random() < 0.25
    return {"albedo": [float(x) for x in rng.uniform(0.05, 0.95, 3)],
            "roughness": float(rng.uniform(0.05, 1.0)),
            "metallic": 1.0 if metal else float(rng.uniform(0.0, 0.1)),
            "specular": float(rng.uniform(0.2, 1.0)),
            "ao": float(rng.uniform(0.6, 1.0))}


def _rotation(rng) -> list[list[float]]:
    a, b = rng.uniform(0, 2 * math.pi, 2)
    ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
    ry = np.array([[ca, 0, sa], [0, 1, 0], [-sa, 0, ca]])
    rx = np.array([[1, 0, 0], [0, cb, -sb], [0, sb, cb]])
    return (ry @ rx).tolist()


def _yaw(a: float) -> np.ndarray:
    """Rotation about +Y by ``a`` radians."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _pitch(a: float) -> np.ndarray:
    """Rotation about +X by ``a`` radians."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


# resting poses of the random scenes' trimesh meshes, as pitches (about x) before a yaw: the box
# on a face; the torus (axis z) lying flat or standing on its rim; the capsule (axis z) standing
# or lying
_POSES = {"box": (0.0,), "torus": (-math.pi / 2, 0.0), "capsule": (-math.pi / 2, 0.0)}


@functools.lru_cache(maxsize=32)
def _vertices(path: str) -> np.ndarray:
    """The positions of mesh file ``path`` as the renderer loads them (float64 ``[N, 3]``)."""
    return np.concatenate([m.positions for m in load_mesh(path)]).astype(np.float64)


def _footprint(body: dict) -> tuple[float, float, float, float]:
    """``(cx, cz, radius, lowest y)`` of a body (``{"radius"}``: a sphere about the origin;
    ``{"path", "linear"}``: a mesh file under a 3 x 3 map): the centre and radius of the circle
    bounding its floor-plane projection, and its lowest point."""
    if "radius" in body:
        return 0.0, 0.0, float(body["radius"]), -float(body["radius"])
    v = _vertices(str(body["path"])) @ np.asarray(body["linear"]).T
    lo, hi = v.min(0), v.max(0)
    cx, cz = (lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2
    return float(cx), float(cz), float(np.hypot(v[:, 0] - cx, v[:, 2] - cz).max()), float(lo[1])


def _resting(body: dict, x: float, z: float, floor_y: float, material: dict | None) -> dict:
    """The scene object of ``body`` resting on the floor ``y = floor_y`` (its lowest point on
    it), its footprint centred on ``(x, z)``; a mesh without ``material`` keeps its file's own
    materials (glTF textures)."""
    if "radius" in body:
        r = float(body["radius"])
        return {"type": "sphere", "center": [float(x), floor_y + r, float(z)], "radius": r,
                "material": material}
    cx, cz, _, low = _footprint(body)
    m = np.eye(4)
    m[:3, :3] = body["linear"]
    m[:3, 3] = [x - cx, floor_y - low, z - cz]
    obj = {"type": "mesh", "path": str(body["path"]), "transform": m.tolist()}
    if material is not None:
        obj["material"] = material
    return obj


def _touching_distance(a: dict, b: dict) -> float:
    """The horizontal centre distance at which two resting bodies touch: two spheres on one floor
    (radii r, s) at 2 sqrt(r s); otherwise where their bounding footprint circles touch."""
    if "radius" in a and "radius" in b:
        return 2.0 * math.sqrt(a["radius"] * b["radius"])
    return _footprint(a)[2] + _footprint(b)[2]


def _place(rng, bodies: list[dict], cx: float, cz: float) -> list[tuple[float, float] | None]:
    """Floor positions for ``bodies``: the first at ``(cx, cz)``, each next one beside a placed
    one, touching it (half the time) or a little apart, overlapping none, within 1.3 of the first
    (up to 64 tries; a body that finds no room is left out: None)."""
    placed: list[tuple[int, float, float]] = []
    out: list[tuple[float, float] | None] = [None] * len(bodies)
    for k, b in enumerate(bodies):
        if not placed:
            x, z = cx, cz
        else:
            rho = _footprint(b)[2]
            for _ in range(64):
                j, xj, zj = placed[int(rng.integers(0, len(placed)))]
                a = float(rng.uniform(0.0, 2 * math.pi))
                gap = 0.0 if rng.random() < 0.5 else float(rng.uniform(0.02, 0.3)) * rho
                d = _touching_distance(bodies[j], b) + gap
                x, z = xj + d * math.cos(a), zj + d * math.sin(a)
                if z < -2.6 and math.hypot(x - cx, z - cz) < 1.3 and all(math.hypot(x - xi, z - zi) >= _touching_distance(bodies[i], b)
                                    - 1e-9 for i, xi, zi in placed):
                    break
            else:
                continue
        placed.append((k, x, z))
        out[k] = (x, z)
    return out


def _camera(fov: float, size: int) -> dict:
    return {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov_y": fov,
            "size": [size, size]}


def _floor(y: float, material: dict) -> dict:
    return {"type": "plane", "center": [0.0, y, -4.0], "size": [12.0, 12.0], "material": material}


def _cluster_scene(kind: str, rng, config: GeneratorConfig, meshes: dict[str, Path],
                   shapes: dict[str, Path]) -> dict:
    """"cluster": 3-6 spheres and meshes; "gltf": 1-3 bodies, the first a glTF model, the others
    glTF models or spheres; all resting on a floor, touching or close to each other."""
    floor_y = float(rng.uniform(-1.1, -0.7))
    cx, cz = float(rng.uniform(-0.4, 0.4)), float(rng.uniform(-4.4, -3.6))
    fov = float(rng.uniform(35.0, 50.0))
    names = sorted(meshes) if config.meshes else []
    bodies, materials = [], []
    n = int(rng.integers(3, 7)) if kind == "cluster" else int(rng.integers(1, 4))
    for k in range(n):
        if kind == "gltf" and (k == 0 or rng.random() < 0.5):
            name = GLTF_MODELS[int(rng.integers(0, len(GLTF_MODELS)))]
            linear = _yaw(float(rng.uniform(0, 2 * math.pi))) * float(rng.uniform(0.8, 1.3))
            bodies.append({"path": shapes[name], "linear": linear})
            materials.append(None)  # the file's textured material
            continue
        if kind == "cluster" and names and rng.random() < 0.45:
            name = names[int(rng.integers(0, len(names)))]
            poses = _POSES.get(name, (0.0,))
            pitch = poses[int(rng.integers(0, len(poses)))]
            linear = (_yaw(float(rng.uniform(0, 2 * math.pi))) @ _pitch(pitch)
                      * float(rng.uniform(0.4, 0.7)))
            bodies.append({"path": meshes[name], "linear": linear})
        else:
            bodies.append({"radius": float(rng.uniform(0.2, 0.45))})
        materials.append(_material(rng))
    where = _place(rng, bodies, cx, cz)
    objects = [_resting(b, *xz, floor_y, m) for b, xz, m in zip(bodies, where, materials)
               if xz is not None]
    objects.append(_floor(floor_y, _material(rng)))
    return {"camera": _camera(fov, config.size), "objects": objects}


def _concave_scene(kind: str, rng, config: GeneratorConfig, shapes: dict[str, Path]) -> dict:
    """"concave": one concave shape (CONCAVE_SHAPES) resting on a floor; "nested": the same with a
    sphere resting inside it (:func:`_nested_spot`). A corner opens towards the camera."""
    shape = CONCAVE_SHAPES[int(rng.integers(0, len(CONCAVE_SHAPES)))]
    scale = float(rng.uniform(0.8, 1.15))
    yaw = (-math.pi / 4 + float(rng.uniform(-0.5, 0.5)) if shape == "corner"
           else float(rng.uniform(0, 2 * math.pi)))
    floor_y = float(rng.uniform(-1.35, -1.0))  # seen from above: the inside shows
    x, z = float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-3.4, -2.8))
    fov = float(rng.uniform(50.0, 60.0))
    mesh = _resting({"path": shapes[shape], "linear": _yaw(yaw) * scale}, x, z, floor_y,
                    _material(rng))
    objects = [mesh]
    if kind == "nested":
        local, rs = _nested_spot(shape, rng)
        t = np.asarray(mesh["transform"])
        c = t[:3, :3] @ local + t[:3, 3]
        objects.append({"type": "sphere", "center": [float(v) for v in c],
                        "radius": rs * scale, "material": _material(rng)})
    objects.append(_floor(floor_y, _material(rng)))
    return {"camera": _camera(fov, config.size), "objects": objects}


def random_scene(rng, config: GeneratorConfig, meshes: dict[str, Path]) -> dict:
    """A scene dict (``viewer.scene.scene_from_dict`` format) without its environment."""
    objects = []
    for k in range(int(rng.integers(1, 4))):
        center = [float(rng.uniform(-1.0, 1.0)), float(rng.uniform(-0.4, 0.6)),
                  float(rng.uniform(-4.5, -3.0))]
        radius = float(rng.uniform(0.4, 0.8))
        if meshes and config.meshes and rng.random() < 0.4:
            name = sorted(meshes)[int(rng.integers(0, len(meshes)))]
            rot = np.array(_rotation(rng)) * radius * 1.2
            m = np.eye(4)
            m[:3, :3] = rot
            m[:3, 3] = center
            objects.append({"type": "mesh", "path": str(meshes[name]), "transform": m.tolist(),
                            "material": _material(rng)})
        else:
            objects.append({"type": "sphere", "center": center, "radius": radius,
                            "material": _material(rng)})
    if rng.random() < 0.75:
        objects.append({"type": "plane", "center": [0.0, float(rng.uniform(-1.2, -0.7)), -4.0],
                        "size": [12.0, 12.0], "material": _material(rng)})
    fov = float(rng.uniform(30.0, 50.0))
    return {"camera": {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0],
                       "fov_y": fov, "size": [config.size, config.size]},
            "objects": objects}


def kind_scene(kind: str, rng, config: GeneratorConfig, meshes: dict[str, Path],
               shapes: dict[str, Path] | None = None) -> dict:
    """The scene dict of sample kind ``kind`` (:data:`SCENE_KINDS`), without its environment.
    ``shapes``: the concave shapes and glTF models (:func:`_shape_files`) the kinds cluster,
    concave, gltf and nested draw from."""
    if kind == "random":
        return random_scene(rng, config, meshes)
    if kind in ("cluster", "gltf", "concave", "nested"):
        if kind != "cluster" and not shapes:
            raise DatasetError(f"scene kind {kind!r} needs the generator's shape files "
                               "(_shape_files)", where="scene_kinds")
        if kind in ("cluster", "gltf"):
            return _cluster_scene(kind, rng, config, meshes, shapes or {})
        return _concave_scene(kind, rng, config, shapes)
    fov = float(rng.uniform(30.0, 45.0))
    camera = {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov_y": fov,
              "size": [config.size, config.size]}
    if kind == "convex":
        objects = [{"type": "sphere", "center": [float(rng.uniform(-0.3, 0.3)),
                                                 float(rng.uniform(-0.3, 0.3)),
                                                 float(rng.uniform(-4.0, -3.0))],
                    "radius": float(rng.uniform(0.5, 0.8)), "material": _material(rng)}]
        return {"camera": camera, "objects": objects}
    floor_y = float(rng.uniform(-1.0, -0.6))
    z = float(rng.uniform(-4.0, -3.2))
    if kind == "sphere_on_plane":
        r = float(rng.uniform(0.4, 0.7))
        spheres = [([float(rng.uniform(-0.5, 0.5)), floor_y + r, z], r)]
    elif kind == "touching_spheres":
        r1, r2 = (float(x) for x in rng.uniform(0.3, 0.6, 2))
        a = float(rng.uniform(-0.6, 0.6))  # the second sphere's direction in the floor plane
        d = r1 + r2
        dx, dz = math.cos(a), math.sin(a)
        c1 = [-0.5 * d * dx, floor_y + r1, z - 0.5 * d * dz]
        # touching: centres d apart, both on the floor (offset in y by r2 - r1)
        h = math.sqrt(max(d * d - (r2 - r1) ** 2, 0.0))
        c2 = [c1[0] + h * dx, floor_y + r2, c1[2] + h * dz]
        spheres = [(c1, r1), (c2, r2)]
    else:
        raise DatasetError(f"unknown scene kind {kind!r} (known: {', '.join(SCENE_KINDS)})",
                           where="scene_kinds")
    objects = [{"type": "sphere", "center": c, "radius": r, "material": _material(rng)}
               for c, r in spheres]
    objects.append({"type": "plane", "center": [0.0, floor_y, -4.0], "size": [12.0, 12.0],
                    "material": _material(rng)})
    return {"camera": camera, "objects": objects}


def random_environment(rng, config: GeneratorConfig) -> tuple[np.ndarray, dict]:
    """An equirect ``[H, W, 3]`` radiance image (intensity and rotation baked) and its recipe."""
    choices = list(config.env_procedural) + list(config.env_paths)
    pick = choices[int(rng.integers(0, len(choices)))]
    if pick in PROCEDURAL_ENVIRONMENTS:
        spec = EnvironmentSpec(procedural=pick, width=config.env_width,
                               sun_elevation_deg=float(rng.uniform(10.0, 70.0)),
                               sun_azimuth_deg=float(rng.uniform(-180.0, 180.0)))
        env = load_environment(spec)
    else:  # a file: loaded (and its texel warnings given) once per process
        env = _file_environment(str(env_file(pick)), config.env_width)
    if env.shape[1] != config.env_width:

        env = resample(env, config.env_width, config.env_width // 2)
    intensity = float(rng.uniform(0.5, 1.5)) * (0.05 if pick == "sky" else 1.0) ** 0.5
    shift = int(rng.integers(0, env.shape[1]))  # a rotation about +Y by whole texels
    env = np.roll(env, shift, axis=1) * intensity
    return env.astype(np.float32), {"source": pick, "intensity": intensity,
                                    "rotation_texels": shift}


@functools.lru_cache(maxsize=8)
def _file_environment(path: str, width: int) -> np.ndarray:
    env = load_environment(EnvironmentSpec(path=path, width=width))
    env.setflags(write=False)
    return env


def env_file(path: str) -> Path:
    """An environment file of ``env_paths``: as given, or (the repository-relative
    :data:`ENVIRONMENTS`) under the repository root, so datasets do not depend on the working
    directory and ``dataset.json`` holds no absolute path."""
    p = Path(path)
    if not p.is_file() and not p.is_absolute() and (ASSET_ROOT.parent / p).is_file():
        return ASSET_ROOT.parent / p
    return p


def _env_identity(pick: str) -> str:
    return pick if pick in PROCEDURAL_ENVIRONMENTS else str(env_file(pick).resolve())


def held_out_config(config: GeneratorConfig, env_paths: tuple[str, ...] = HELD_OUT_ENV_PATHS,
                    scene_kinds: tuple[str, ...] = HELD_OUT_KINDS, seed: int | None = None,
                    **changes) -> GeneratorConfig:
    """The configuration of an evaluation dataset that no training sample of ``config`` shares an
    environment or a scene kind with: ``env_paths`` (default the esplanade HDRI) with no
    procedural environment, ``scene_kinds`` (default :data:`HELD_OUT_KINDS`), another seed
    (default ``config.seed + 1``), the rest of ``config`` (``changes`` override fields: count,
    size...). A one-line :class:`DatasetError` when an environment file or a kind is shared.

        train = GeneratorConfig(targets="reference", env_paths=TRUTH_ENV_PATHS,
                                scene_kinds=TRUTH_KINDS)
        test = held_out_config(train, count=20)   # esplanade; nested and convex scenes"""
    from dataclasses import replace

    out = replace(config, env_paths=tuple(env_paths), env_procedural=(),
                  scene_kinds=tuple(scene_kinds),
                  seed=config.seed + 1 if seed is None else int(seed), **changes)
    train_envs = {_env_identity(e) for e in (*config.env_procedural, *config.env_paths)}
    shared = [e for e in out.env_paths if _env_identity(e) in train_envs]
    if shared:
        raise DatasetError(f"held-out environment {shared[0]!r} is one the training "
                           "configuration draws from", where="env_paths")
    kinds = sorted(set(out.scene_kinds) & set(config.scene_kinds))
    if kinds:
        raise DatasetError(f"held-out scene kind {kinds[0]!r} is one the training configuration "
                           "draws from", where="scene_kinds")
    check_config(replace(out, targets="rasteriser"))
    return out


def check_config(config: GeneratorConfig, tracer=None) -> None:
    """One-line :class:`DatasetError` for a configuration that cannot be generated (before any
    sample is written). ``targets = "reference"`` needs ``tracer``: ``learned`` does not import
    ``relight``, so the caller hands the path tracer in (``relight.commands.reference_tracer()``,
    which names what to install when Mitsuba or a libLLVM >= 19 is missing)."""
    if config.targets not in TARGETS:
        raise DatasetError(f"targets {config.targets!r} is not one of {', '.join(TARGETS)}",
                           where="targets")
    if not config.scene_kinds:
        raise DatasetError("scene_kinds is empty (use ('random',))", where="scene_kinds")
    for kind in config.scene_kinds:
        if kind not in SCENE_KINDS:
            raise DatasetError(f"unknown scene kind {kind!r} (known: {', '.join(SCENE_KINDS)})",
                               where="scene_kinds")
    for name in config.env_procedural:
        if name not in PROCEDURAL_ENVIRONMENTS:
            raise DatasetError(f"env_procedural {name!r} is not one of "
                               f"{', '.join(PROCEDURAL_ENVIRONMENTS)}", where="env_procedural")
    if not config.env_procedural and not config.env_paths:
        raise DatasetError("no environment to draw from: give env_paths or env_procedural",
                           where="env_paths")
    for path in config.env_paths:
        if not env_file(path).is_file():
            raise DatasetError("environment file not found", where=path)
    if not 0.0 <= config.degrade <= 1.0:
        raise DatasetError(f"degrade {config.degrade} is not in [0, 1]", where="degrade")
    if config.targets == "reference":
        if config.gbuffer_fraction > 0:
            raise DatasetError("image G-buffers have no geometry to path-trace: use "
                               "gbuffer_fraction = 0 with targets = 'reference'",
                               where="gbuffer_fraction")
        if config.reference_spp < 2 or config.reference_depth < 2:
            raise DatasetError("reference_spp and reference_depth must be at least 2 (the "
                               "standard error needs 2 samples; depth 2 = direct light)",
                               where="reference_spp")
        if tracer is None:
            raise DatasetError("targets = 'reference' needs a path tracer: generate(..., "
                               "tracer=relight.commands.reference_tracer()) or relight train "
                               "--targets reference", where="targets")


def shard_of(index: int, rank: int, world: int) -> bool:
    """Whether sample ``index`` belongs to ``rank`` of ``world`` (round robin: i % world)."""
    return index % world == rank


def _rank_world() -> tuple[int, int]:
    return int(os.environ.get("RANK", "0")), max(1, int(os.environ.get("WORLD_SIZE", "1")))


def generate(root: str | os.PathLike, config: GeneratorConfig = GeneratorConfig(),
             renderer=None, progress: bool = True, shard: bool = False,
             wait_s: float = 7 * 24 * 3600.0, tracer=None) -> dict:
    """Write ``config.count`` samples under ``root/<split>/<name>``; finished ones are kept.

    ``shard``: this process writes only the samples of its torchrun rank (``RANK`` /
    ``WORLD_SIZE``: sample i belongs to rank i % WORLD_SIZE), then waits (up to ``wait_s``) until
    the other ranks' samples exist, so every rank returns with the whole dataset (a file-system
    barrier: no process group needed). ``tracer`` (``targets = "reference"``):
    ``tracer(scene, spp=, max_depth=, seed=, checkpoint=)`` -> an object with ``radiance``
    ``[H, W, >=3]``, ``stderr`` ``[H, W, 3]`` and ``meta`` (a ``relight.reference.Reference``)."""
    import time

    check_config(config, tracer)
    rank, world = _rank_world() if shard else (0, 1)
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    info = {"format": FORMAT, "config": asdict(config), "targets": target_settings(config.samples),
            "unoccluded_targets": unoccluded_settings(config.samples)}
    if config.targets == "reference":
        info["targets"] = {"source": "reference", "spp": config.reference_spp,
                           "max_depth": config.reference_depth, "rays": "pixel centre"}
    info_path = root / "dataset.json"
    if info_path.is_file():
        old = json.loads(info_path.read_text())
        new = json.loads(json.dumps(info["config"]))
        # fields added since a dataset was written take their defaults (which reproduce it)
        defaults = json.loads(json.dumps(asdict(GeneratorConfig())))
        if defaults | old.get("config", {}) | {"count": 0} != new | {"count": 0}:

            raise DatasetError("was generated with another configuration; use a new folder "
                               "(nothing was overwritten)", where=info_path)
    tmp_info = root / f"dataset.json.tmp{rank}"
    tmp_info.write_text(json.dumps(info, indent=1))
    os.replace(tmp_info, info_path)
    meshes = _mesh_files(root / "_meshes", rank) if config.meshes else {}
    shapes = (_shape_files(root / "_meshes", rank)
              if set(config.scene_kinds) & {"cluster", "concave", "gltf", "nested"} else {})
    mine = [i for i in range(config.count) if shard_of(i, rank, world)]
    own = renderer is None
    renderer = renderer or Renderer()
    done = skipped = 0
    try:
        bar = tqdm(mine, desc="generate" + (f" [rank {rank}/{world}]" if world > 1 else ""),
                   unit="sample", disable=not progress)
        for i in bar:
            name = f"{i:06d}"
            final = root / split_of(i) / name
            if final.is_dir():
                skipped += 1
                continue
            _write_sample(renderer, final, i, config, meshes, write_exr, scene_from_dict, tracer,
                          shapes)
            done += 1
    finally:
        if own:
            renderer.release()
    out = {"written": done, "kept": skipped, "root": str(root)}
    if world > 1:
        out["rank"], out["world_size"] = rank, world
        deadline = time.monotonic() + wait_s
        while True:
            missing = [i for i in range(config.count)
                       if not (root / split_of(i) / f"{i:06d}").is_dir()]
            if not missing:
                break
            if time.monotonic() > deadline:
                raise DatasetError(f"rank {rank}: {len(missing)} samples of other ranks still "
                                   f"missing after {wait_s:.0f} s (first: {missing[0]:06d})",
                                   where=root)
            time.sleep(1.0)
    return out


def _smooth_field(rng, size: int, cells: int) -> np.ndarray:
    """``[size, size, 1]`` in [0, 1]: bilinear upsampling of a random ``cells`` x ``cells`` grid."""
    grid = rng.random((cells, cells)).astype(np.float32)
    t = (np.arange(size, dtype=np.float32) + 0.5) / size * (cells - 1)
    i0 = np.clip(np.floor(t).astype(int), 0, cells - 2)
    f = t - i0
    rows = grid[i0] * (1 - f)[:, None] + grid[i0 + 1] * f[:, None]  # [size, cells]
    out = rows[:, i0] * (1 - f)[None, :] + rows[:, i0 + 1] * f[None, :]
    return out[..., None]


def perturb_materials(channels: dict, rng) -> tuple[dict, dict]:
    """Spatially varying materials on an image G-buffer (channel -> ``[H, W, C]``, square):
    albedo times a random tint and a smooth field, roughness / specular blended towards random
    smooth fields, metallic set where a smooth field exceeds a random threshold, AO darkened by a
    smooth field. Returns the new channels and the recipe (for ``meta.json``)."""
    size = channels["albedo"].shape[0]
    cells = int(rng.integers(2, 7))
    tint = rng.uniform(0.4, 1.2, 3).astype(np.float32)
    mix = float(rng.uniform(0.3, 1.0))
    metal_threshold = float(rng.uniform(0.6, 1.0))
    fields = [_smooth_field(rng, size, cells) for _ in range(5)]
    out = dict(channels)
    out["albedo"] = np.clip(channels["albedo"] * tint * (0.5 + fields[0]), 0.02, 0.95)
    out["roughness"] = np.clip((1 - mix) * channels["roughness"] + mix * (0.05 + 0.95 * fields[1]),
                               0.0, 1.0)
    out["specular"] = np.clip((1 - mix) * channels["specular"] + mix * (0.2 + 0.8 * fields[2]),
                              0.0, 1.0)
    out["metallic"] = np.where(fields[3] > metal_threshold, 1.0,
                               channels["metallic"]).astype(np.float32)
    out["ao"] = np.clip(channels["ao"] * (0.6 + 0.4 * fields[4]), 0.0, 1.0)
    fg = channels["alpha"] > 0.0
    for k in ("albedo", "roughness", "specular", "metallic", "ao"):
        out[k] = np.where(fg, out[k], channels[k]).astype(np.float32)
    recipe = {"cells": cells, "tint": [float(x) for x in tint], "mix": mix,
              "metal_threshold": metal_threshold}
    return out, recipe


def _masked_blur(img: np.ndarray, mask: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur (``sigma`` pixels) of ``img`` ``[H, W, C]`` over the pixels of ``mask``
    ``[H, W]`` alone (normalised by the blurred mask: the background does not bleed in)."""
    def kernel(n):
        x = np.arange(n, dtype=np.float64)
        k = np.exp(-0.5 * ((x[:, None] - x[None, :]) / max(sigma, 1e-3)) ** 2)
        return k / k.sum(1, keepdims=True)

    gy, gx = kernel(img.shape[0]), kernel(img.shape[1])
    m = mask.astype(np.float64)[..., None]
    num = np.einsum("ij,jkc,lk->ilc", gy, img.astype(np.float64) * m, gx)
    den = np.einsum("ij,jkc,lk->ilc", gy, m, gx)
    return num / np.maximum(den, 1e-12)


def degrade_inputs(channels: dict, radiance: np.ndarray, rng,
                   strength: float = 1.0) -> tuple[dict, dict]:
    """G-buffer inputs wrong the way inverse rendering's estimates are (thesis ch. 4's setting),
    on the foreground pixels; ``strength`` in [0, 1] scales every error:

    - normals: plus a smooth random field (amplitude ~0.15-0.35) and per-pixel Gaussian noise
      (~0.03-0.12), renormalised;
    - albedo: shading baked in: times ``S ** bake`` (bake ~0.3-0.8), S the luminance of
      ``radiance`` (the unoccluded render) blurred over the foreground (sigma 2-6 % of the
      width), relative to its foreground median (clipped to [0.1, 10]), albedo clipped to [0, 1];
    - roughness: biased, ``r * scale + offset`` (scale 1 +- 0.4, offset -0.1..0.15), clipped to
      [0.02, 1].

    Returns the new channels (the others shared) and the recipe (for ``meta.json``)."""
    s = float(strength)
    fg2 = channels["alpha"][..., 0] > 0.0
    fg = fg2[..., None]
    size = channels["normal"].shape[0]
    cells = int(rng.integers(3, 9))
    smooth_amp = s * float(rng.uniform(0.15, 0.35))
    pixel_amp = s * float(rng.uniform(0.03, 0.12))
    field = np.concatenate([_smooth_field(rng, size, cells) for _ in range(3)], -1) * 2 - 1
    noise = rng.standard_normal(channels["normal"].shape).astype(np.float32)
    n = channels["normal"] + smooth_amp * field + pixel_amp * noise
    n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-8)
    bake = s * float(rng.uniform(0.3, 0.8))
    sigma = size * float(rng.uniform(0.02, 0.06))
    lum = (radiance[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722]))[..., None]
    shade = _masked_blur(lum, fg2, sigma)
    med = float(np.median(shade[fg2])) if fg2.any() else 1.0
    shade = np.clip(shade / max(med, 1e-8), 0.1, 10.0)
    albedo = np.clip(channels["albedo"] * shade ** bake, 0.0, 1.0)
    scale = 1.0 + s * float(rng.uniform(-0.4, 0.4))
    offset = s * float(rng.uniform(-0.1, 0.15))
    rough = np.clip(channels["roughness"] * scale + offset, 0.02, 1.0)
    out = dict(channels)
    out["normal"] = np.where(fg, n, channels["normal"]).astype(np.float32)
    out["albedo"] = np.where(fg, albedo, channels["albedo"]).astype(np.float32)
    out["roughness"] = np.where(fg, rough, channels["roughness"]).astype(np.float32)
    recipe = {"strength": s,
              "normal": {"cells": cells, "smooth": smooth_amp, "pixel": pixel_amp},
              "albedo": {"bake": bake, "sigma_px": sigma, "shading": "unoccluded render"},
              "roughness": {"scale": scale, "offset": offset}}
    return out, recipe


def _resize_nearest(channels: dict, size: int) -> dict:
    h, w = channels["albedo"].shape[:2]
    if (h, w) == (size, size):
        return channels
    ys = ((np.arange(size) + 0.5) * h / size).astype(int)
    xs = ((np.arange(size) + 0.5) * w / size).astype(int)
    return {k: np.ascontiguousarray(v[ys][:, xs]) for k, v in channels.items()}


def _load_gbuffer_source(path: str):
    p = Path(path)
    gb = load_stack_exr(p) if p.is_file() else load_ffhq_pbr(p)
    return gb.channels, float(gb.fov_y)


def _write_gbuffer(folder: Path, channels: dict, fov_y: float, write_exr) -> None:
    """Write G-buffer channels (the renderer's AOV names) as an FFHQ256-PBR folder (no rgb/env)."""
    fg = channels["alpha"] > 0.0
    write_exr(folder / "albedo.exr", channels["albedo"], ["R", "G", "B"])
    write_exr(folder / "normal.exr", np.where(fg, channels["normal"] * 0.5 + 0.5, 0.5),
              ["R", "G", "B"])
    for name in ("roughness", "metallic", "specular", "depth", "ao"):
        write_exr(folder / f"{name}.exr", channels[name], ["Y"])
    write_exr(folder / "mask.exr", channels["alpha"], ["Y"])
    (folder / "camera.json").write_text(json.dumps({"fov_y": fov_y}))


_AOVS = ("albedo", "normal", "roughness", "metallic", "specular", "depth", "ao", "alpha")


def _gbuffer_geometry(renderer, tmp: Path, index: int, config: GeneratorConfig, meshes,
                      scene_from_dict, write_exr) -> tuple[dict, dict] | None:
    """For an image-G-buffer sample: ``({"objects": [one gbuffer object reading the perturbed
    stack written to tmp/_source], "camera": {"fov_y"}}, geometry recipe)``; None for a sample
    with primitive/mesh geometry (decided by the sample's own stream ``[seed, index, 1]``)."""
    grng = np.random.default_rng([config.seed, index, 1])
    if not grng.random() < config.gbuffer_fraction:
        return None
    if config.gbuffers:
        src = config.gbuffers[int(grng.integers(0, len(config.gbuffers)))]
        channels, fov = _load_gbuffer_source(src)
        channels = _resize_nearest(channels, config.size)
        recipe = {"kind": "gbuffer", "source": str(src)}
    else:  # a previously rendered G-buffer of a random primitive/mesh scene
        base = random_scene(grng, config, meshes)
        base["environment"] = {"procedural": "studio", "width": 32}
        base["render"] = {"model": "unlit", "tonemap": "none"}
        frame = renderer.render(scene_from_dict(base, file=str(tmp / "scene")), aovs=_AOVS)
        channels = {k: frame.aovs[k] for k in _AOVS}
        fov = float(base["camera"]["fov_y"])
        recipe = {"kind": "gbuffer", "source": "rendered",
                  "objects": [o["type"] for o in base["objects"]]}
    channels, recipe["perturbation"] = perturb_materials(channels, grng)
    source = tmp / "_source"
    source.mkdir()
    _write_gbuffer(source, channels, fov, write_exr)
    return {"objects": [{"type": "gbuffer", "path": str(source)}], "camera": {"fov_y": fov}}, recipe


def _write_sample(renderer, final: Path, index: int, config: GeneratorConfig, meshes, write_exr,
                  scene_from_dict, tracer=None, shapes=None) -> None:
    rng = np.random.default_rng([config.seed, index])
    tmp = final.with_name(final.name + ".tmp")
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    kind = config.scene_kinds[index % len(config.scene_kinds)]
    scene_dict = kind_scene(kind, rng, config, meshes, shapes)
    truth = config.targets == "reference"
    if truth:  # the path tracer computes visibility itself: no baked AO in the inputs either
        for o in scene_dict["objects"]:
            if "material" in o:  # (a glTF model without one has no occlusion map)
                o["material"]["ao"] = 1.0
    env, env_info = random_environment(rng, config)
    image = _gbuffer_geometry(renderer, tmp, index, config, meshes, scene_from_dict, write_exr)
    geometry = {"kind": "primitives" if kind == "random" else kind}
    if image is not None:  # the image G-buffer replaces the objects; it sets its own camera
        parts, geometry = image
        scene_dict = {"objects": parts["objects"], "camera": scene_dict["camera"] | parts["camera"]}
    write_exr(tmp / "env.exr", env, ["R", "G", "B"])
    scene_dict["environment"] = {"path": str(tmp / "env.exr")}
    scene_dict["render"] = target_settings(config.samples) | {"seed": int(rng.integers(0, 1 << 30))}
    scene = scene_from_dict(scene_dict, file=str(tmp / "scene"))
    unoccluded_scene = scene.with_render(**unoccluded_settings(config.samples))
    if truth:
        # inputs and the unoccluded target from one rasteriser render; rgb from the path tracer
        frame = renderer.render(unoccluded_scene, aovs=_AOVS)
        unoccluded = frame
        target = _reference_target(tracer, scene, config, int(rng.integers(0, 1 << 30)), final)
        write_exr(tmp / "rgb.exr", target.radiance[..., :3], ["R", "G", "B"])
        write_exr(tmp / STDERR_FILE, target.stderr, ["R", "G", "B"])
        source = {"source": "reference"} | {k: target.meta[k] for k in (
            "spp", "max_depth", "rays", "geometry", "seed", "variant", "mitsuba", "seconds")}
        # the traced BSDF: the scene's render.multiscatter (target_settings leaves it at the
        # default, on), so a single-scattering model is ~6 % dark on rough metals by construction
        source["multiscatter"] = bool(scene.render.multiscatter)
    else:
        frame = renderer.render(scene, aovs=_AOVS)
        write_exr(tmp / "rgb.exr", frame.radiance[..., :3], ["R", "G", "B"])
        unoccluded = renderer.render(unoccluded_scene)
        source = {"source": "rasteriser", "model": scene_dict["render"]["model"]}
    write_exr(tmp / "rgb_unoccluded.exr", unoccluded.radiance[..., :3], ["R", "G", "B"])
    inputs = frame.aovs
    degraded = None
    if config.degrade > 0:  # the written inputs only: the targets are the true scene's
        inputs, degraded = degrade_inputs(frame.aovs, unoccluded.radiance[..., :3],
                                          np.random.default_rng([config.seed, index, 2]),
                                          config.degrade)
    _write_gbuffer(tmp, inputs, float(scene_dict["camera"]["fov_y"]), write_exr)
    meta = {"index": index, "seed": config.seed, "environment": env_info, "geometry": geometry,
            "objects": [{k: v for k, v in o.items() if k != "path"} | (
                {"mesh": Path(o["path"]).stem} if o["type"] == "mesh" else {})
                for o in scene_dict["objects"]],
            "render": scene_dict["render"], "target": source}
    if degraded is not None:
        meta["degrade"] = degraded
    (tmp / "meta.json").write_text(json.dumps(meta, indent=1))
    if (tmp / "_source").exists():
        shutil.rmtree(tmp / "_source")
    os.replace(tmp, final)


def _reference_target(tracer, scene, config: GeneratorConfig, seed: int, final: Path):
    """The path-traced target of ``scene`` (``reference_depth``, ``reference_spp``; the tracer
    shoots pixel-centre rays), checkpointed beside the sample (``<root>/_checkpoints/<name>.npz``:
    an interrupted render resumes there) and removed when it completes."""
    ckpt = final.parent.parent / "_checkpoints" / f"{final.name}.npz"
    ckpt.parent.mkdir(parents=True, exist_ok=True)
    return tracer(scene, spp=int(config.reference_spp), max_depth=int(config.reference_depth),
                  seed=seed, checkpoint=ckpt)
