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
floor, two touching spheres on a floor, and a lone sphere as the convex control), sample i of
kind ``scene_kinds[i % len]``; the default ``("random",)`` leaves datasets unchanged. With
``shard=True`` every torchrun rank writes the samples i with i % WORLD_SIZE == RANK and then waits
for the others' (a file-system barrier).

Deterministic for a seed (sample i draws from ``default_rng([seed, i])``; its split is fixed by i),
resumable (a finished sample is a folder; one being written is ``<name>.tmp`` and is redone), and
shows a tqdm progress bar.
"""
from __future__ import annotations

import json
import math
import os
import shutil
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import trimesh
from tqdm import tqdm

from viewer.environment import EnvironmentSpec, load_environment, resample
from viewer.geometry.imagespace import load_ffhq_pbr, load_stack_exr
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


TARGETS = ("rasteriser", "reference")
# "convex": one sphere alone (truth = the unoccluded target: a control); "sphere_on_plane": a
# sphere resting on a floor (contact shadow); "touching_spheres": two spheres touching, resting on
# a floor (occlusion and inter-reflection between them)
SCENE_KINDS = ("random", "convex", "sphere_on_plane", "touching_spheres")
# the kinds of `relight train --targets reference`: half random scenes, half contact scenes
TRUTH_KINDS = ("random", "sphere_on_plane", "random", "touching_spheres")


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


def kind_scene(kind: str, rng, config: GeneratorConfig, meshes: dict[str, Path]) -> dict:
    """The scene dict of sample kind ``kind`` (:data:`SCENE_KINDS`), without its environment."""
    if kind == "random":
        return random_scene(rng, config, meshes)
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
    choices = ["sky", "sky", "studio"] + list(config.env_paths)
    pick = choices[int(rng.integers(0, len(choices)))]
    if pick in ("sky", "studio"):
        spec = EnvironmentSpec(procedural=pick, width=config.env_width,
                               sun_elevation_deg=float(rng.uniform(10.0, 70.0)),
                               sun_azimuth_deg=float(rng.uniform(-180.0, 180.0)))
    else:
        spec = EnvironmentSpec(path=pick, width=config.env_width)
    env = load_environment(spec)
    if env.shape[1] != config.env_width:

        env = resample(env, config.env_width, config.env_width // 2)
    intensity = float(rng.uniform(0.5, 1.5)) * (0.05 if pick == "sky" else 1.0) ** 0.5
    shift = int(rng.integers(0, env.shape[1]))  # a rotation about +Y by whole texels
    env = np.roll(env, shift, axis=1) * intensity
    return env.astype(np.float32), {"source": pick, "intensity": intensity,
                                    "rotation_texels": shift}


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
            _write_sample(renderer, final, i, config, meshes, write_exr, scene_from_dict, tracer)
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
                  scene_from_dict, tracer=None) -> None:
    rng = np.random.default_rng([config.seed, index])
    tmp = final.with_name(final.name + ".tmp")
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    kind = config.scene_kinds[index % len(config.scene_kinds)]
    scene_dict = kind_scene(kind, rng, config, meshes)
    truth = config.targets == "reference"
    if truth:  # the path tracer computes visibility itself: no baked AO in the inputs either
        for o in scene_dict["objects"]:
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
    else:
        frame = renderer.render(scene, aovs=_AOVS)
        write_exr(tmp / "rgb.exr", frame.radiance[..., :3], ["R", "G", "B"])
        unoccluded = renderer.render(unoccluded_scene)
        source = {"source": "rasteriser", "model": scene_dict["render"]["model"]}
    write_exr(tmp / "rgb_unoccluded.exr", unoccluded.radiance[..., :3], ["R", "G", "B"])
    _write_gbuffer(tmp, frame.aovs, float(scene_dict["camera"]["fov_y"]), write_exr)
    meta = {"index": index, "seed": config.seed, "environment": env_info, "geometry": geometry,
            "objects": [{k: v for k, v in o.items() if k != "path"} | (
                {"mesh": Path(o["path"]).stem} if o["type"] == "mesh" else {})
                for o in scene_dict["objects"]],
            "render": scene_dict["render"], "target": source}
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
