"""``relight bench --suite splat_decomp``: the splat material/light decomposition scored against
relit truth (thesis sec. 6.4.3-4, eqs. 6.24-6.27; the protocol of MaterialFusion's relighting
table).

Per scene of :func:`relight.bench.splat_scenes.decomp_scenes` (spheres of known materials on a
floor):

1. splats on the surfaces carry the true materials
   (:func:`~relight.bench.splat_scenes.surface_splats`);
2. their colours are baked under the capture's environment A
   (:func:`~relight.bench.splat_scenes.bake_traced`: per splat, path-traced outgoing radiance in
   16 directions, shadows and inter-reflection included, fitted with degree-2 SH) - a plain 3DGS
   cloud with no materials;
3. :func:`learned.splats.decompose.decompose` estimates per-splat materials and a cubemap light
   from views of that cloud rendered from an upper ring of cameras (the capture);
   :func:`align_albedo` adds the same materials with the albedo's unknowable scale removed;
4. the estimated materials are relit by the project's renderer (GLSL splat pass,
   ``ggx_split_sum``) under environments B and C it never saw, from a held-out viewpoint, and
   scored against path-traced renders of the *mesh* scene under B and C (Mitsuba 3, our BSDF,
   :func:`~relight.bench.splat_relight.truth_render`) over pixels covered in both.

Beside the decomposition each row has the FLOOR (the baked colours rendered unlit, i.e. the
capture under A shown as it is under B) and the CEILING (the true materials through the same
renderer under B: what a perfect decomposition would score; its gap to truth is the renderer's
own - split-sum shading, no inter-reflection, splat geometry). Every stage is cached in the bench's
cache folder (``splat_decomp/``): baked clouds, decomposition checkpoints and results, reference
renders; a rerun resumes. A final row per method gives the mean PSNR.
"""
from __future__ import annotations

import dataclasses
import hashlib
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from assets import ASSET_ROOT
from viewer.environment.maps import EnvironmentSpec
from viewer.scene.camera import Camera
from viewer.scene.description import Scene
from viewer.splats.data import Splats
from viewer.splats.ply import read_ply, write_ply

from .splat_relight import coverage, render_splats, save_json, score_relit, truth_render
from .splat_scenes import (
    DECOMP_SCENES,
    bake_shaded,
    bake_traced,
    decomp_scenes,
    surface_splats,
)

ENV = ASSET_ROOT / "environments"
CAPTURE = ("park", EnvironmentSpec(path=str(ENV / "park.exr")))  # environment A
RELIGHT = {"sky": EnvironmentSpec(path=str(ENV / "sky.exr")),  # B and C: never seen
           "studio": EnvironmentSpec(procedural="studio")}
METHODS = ("floor", "decomposition", "aligned", "ceiling")


@dataclass(frozen=True)
class SplatDecompConfig:
    size: int = 96            # relit and reference renders, square
    spacing: float = 0.04     # splat spacing on the surfaces (~5k splats per scene)
    bake: str = "traced"      # "traced" (Mitsuba) | "shaded" (torch model, no visibility: tests)
    bake_directions: int = 16
    bake_spp: int = 32
    truth_spp: int = 256
    max_depth: int = 4        # path depth of bake and truth (3 bounces)
    views: int = 6            # decomposition: capture views on an upper ring
    view_size: int = 40
    iterations: int = 100
    light_res: int = 6
    lambda_mat: float = 0.2   # eq. 6.24's lambda_M (decompose's default 0.02 relit worse here)
    scenes: tuple[str, ...] = DECOMP_SCENES
    progress: bool = True
    relight: tuple[str, ...] = tuple(RELIGHT)  # environments of RELIGHT to relight under

    def key(self, *drop: str) -> dict:
        """The options that decide a cached stage: all but ``relight``, ``progress`` and
        ``drop`` (set to None, so keys stay stable)."""
        d = asdict(self)
        d.pop("relight")
        return d | {k: None for k in ("progress",) + drop}


def capture_cameras(views: int, size: int, distance: float = 3.2,
                    target=(0.0, 0.3, 0.0)) -> list[Camera]:
    """``views`` cameras on a ring around ``target`` at elevations alternating 20 and 45 deg
    (a capture walks around the objects; nothing is seen from below the floor)."""
    cams = []
    for i in range(views):
        az = 2 * np.pi * (i + 0.5) / views
        el = np.radians(20.0 if i % 2 == 0 else 45.0)
        p = np.asarray(target) + distance * np.array(
            [np.cos(el) * np.sin(az), np.sin(el), np.cos(el) * np.cos(az)])
        cams.append(Camera(position=tuple(p), target=tuple(target), fov_y=40.0, size=(size, size),
                           near=0.05, far=30.0))
    return cams


def _log(config: SplatDecompConfig, msg: str) -> None:
    if config.progress:
        print(f"splat_decomp: {msg}", file=sys.stderr, flush=True)


def _key(*parts) -> str:
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:12]


def baked_cloud(scene: Scene, truth: Splats, config: SplatDecompConfig, folder: Path
                ) -> Splats:
    """The capture: ``truth``'s colours baked under A (cached as a PLY)."""
    key = _key(scene.objects, CAPTURE, config.spacing, config.bake, config.bake_directions,
               config.bake_spp, config.max_depth)
    path = folder / f"baked_{key}.ply"
    if path.is_file():
        return read_ply(path)
    env = CAPTURE[1]
    t0 = time.perf_counter()
    if config.bake == "traced":
        out, info = bake_traced(dataclasses.replace(scene, environment=env), truth,
                                config.bake_directions, config.bake_spp, config.max_depth)
        _log(config, f"baked {len(truth)} splats x {config.bake_directions} directions x "
                     f"{config.bake_spp} spp in {info['seconds']:.0f} s "
                     f"(misses {100 * info['miss_fraction']:.2f} %)")
    elif config.bake == "shaded":
        out = bake_shaded(truth, env, config.bake_directions)
        _log(config, f"baked {len(truth)} splats (torch shading) in "
                     f"{time.perf_counter() - t0:.0f} s")
    else:
        raise ValueError(f"bake must be 'traced' or 'shaded', not {config.bake!r}")
    write_ply(path, out)
    return read_ply(path)  # what a capture file holds (float32 round trip)


def decomposed(baked: Splats, config: SplatDecompConfig, folder: Path, key: str) -> Splats:
    """The decomposition of ``baked`` (cached PLY; resumable through its checkpoint)."""
    from learned.splats.decompose import DecomposeOptions, decompose

    path = folder / f"decomposed_{key}.ply"
    if path.is_file():
        return read_ply(path)
    options = DecomposeOptions(views=config.views, size=config.view_size,
                               iterations=config.iterations, light_res=config.light_res,
                               lambda_mat=config.lambda_mat,
                               checkpoint=str(folder / f"decompose_{key}.pt"),
                               progress=config.progress)
    result = decompose(baked, options, capture_cameras(config.views, config.view_size))
    _log(config, f"decomposed: re-render PSNR {result.psnr:.2f} dB on the capture views")
    write_ply(path, result.splats)
    return read_ply(path)


def scramble(splats: Splats, seed: int = 0) -> Splats:
    """``splats`` with their materials permuted among splats (right statistics, wrong places)."""
    p = np.random.default_rng(seed).permutation(len(splats))
    return dataclasses.replace(splats, albedo=splats.albedo[p], roughness=splats.roughness[p],
                               metallic=splats.metallic[p])


def invert(splats: Splats) -> Splats:
    """``splats`` with every material value x replaced by 1 - x (a decomposition wrong in a
    known direction: dark where bright, rough where smooth, metal where dielectric)."""
    return dataclasses.replace(splats, albedo=1.0 - splats.albedo,
                               roughness=1.0 - splats.roughness, metallic=1.0 - splats.metallic)


def align_albedo(estimate: Splats, truth: Splats) -> Splats:
    """``estimate`` with its albedo scaled per channel by the ratio of the medians of the true
    and estimated albedo (clamped to [0, 1]): the scale a decomposition cannot know (albedo x
    light), removed as NeRFactor, TensoIR and MaterialFusion do before relighting."""
    scale = np.median(truth.albedo, 0) / np.maximum(np.median(estimate.albedo, 0), 1e-4)
    return dataclasses.replace(estimate, albedo=np.clip(estimate.albedo * scale, 0, 1)
                               .astype(np.float32))


def scene_rows(renderer, name: str, scene: Scene, config: SplatDecompConfig, folder: Path,
               extra: dict | None = None, truth_fn=None) -> list[dict]:
    """One row per relighting environment of scene ``name``: PSNR etc. of each method. ``extra``:
    more clouds to score the same way (name -> function of the decomposed splats, e.g.
    :func:`scramble`); ``truth_fn(scene, env, name)``: the reference (default:
    :func:`truth_render` at ``config.truth_spp``)."""
    truth = surface_splats(scene, config.spacing)
    baked = baked_cloud(scene, truth, config, folder)
    key = _key(name, scene.objects, config.key("size", "truth_spp", "scenes"))
    estimate = decomposed(baked, config, folder, key)
    clouds = {"floor": baked, "decomposition": estimate,
              "aligned": align_albedo(estimate, truth), "ceiling": truth}
    clouds |= {k: f(estimate) for k, f in (extra or {}).items()}
    mae = {f"{k}_mae": float(np.abs(getattr(estimate, k) - getattr(truth, k)).mean())
           for k in ("albedo", "roughness", "metallic")}
    rows = []
    for env_name in config.relight:
        env = RELIGHT[env_name]
        if truth_fn is None:
            ref = truth_render(scene, env, folder, f"truth_{name}_{env_name}", config.truth_spp,
                               config.max_depth, progress=config.progress)
        else:
            ref = truth_fn(scene, env, env_name)
        images = {m: render_splats(renderer, scene, c, env, folder, f"{name}_{m}",
                                   model="unlit" if m == "floor" else "ggx_split_sum")
                  for m, c in clouds.items()}
        mask = coverage(images["ceiling"], ref)
        for m in images:
            mask &= coverage(images[m], ref)
        row = {"scene": name, "capture": CAPTURE[0], "relit": env_name,
               "size": f"{config.size}x{config.size}", "splats": len(truth),
               "truth_spp": ref.meta.get("spp")}
        for m, image in images.items():
            s = score_relit(image, ref, mask)
            row[f"psnr_{m}"] = s["psnr"]
            row[f"psnr_ldr_{m}"] = s["psnr_ldr"]
            row[f"bias_{m}_%"] = s["bias_%"]
        row["pixels"] = int(mask.sum())
        row |= mae
        rows.append(row)
        _log(config, f"{name} relit under {env_name}: " + ", ".join(
            f"{m} {row[f'psnr_{m}']:.2f} dB" for m in images))
    return rows


def mean_row(rows: list[dict], methods=METHODS) -> dict:
    out = {"scene": "mean", "relit": f"{len(rows)} scene x environment pairs"}
    for m in methods:
        out[f"psnr_{m}"] = float(np.mean([r[f"psnr_{m}"] for r in rows]))
        out[f"psnr_ldr_{m}"] = float(np.mean([r[f"psnr_ldr_{m}"] for r in rows]))
    out["decomposition_minus_floor_db"] = out["psnr_decomposition"] - out["psnr_floor"]
    out["ldr_decomposition_minus_floor_db"] = (out["psnr_ldr_decomposition"]
                                               - out["psnr_ldr_floor"])
    return out


TABLE_KEYS = ("scene", "relit") + tuple(f"psnr_{m}" for m in METHODS) \
    + tuple(f"psnr_ldr_{m}" for m in METHODS)


def table_row(row: dict) -> dict:
    """``row`` with the table's columns (:data:`TABLE_KEYS`, the mean row's differences) in
    front and the rest (capture, sizes, biases, material errors) under ``details`` (in the
    JSON, not the markdown table)."""
    head = {k: row[k] for k in TABLE_KEYS if k in row}
    head |= {k: v for k, v in row.items() if k.endswith("_db")}
    return head | {"details": {k: v for k, v in row.items() if k not in head}}


def splat_decomp_rows(renderer, cache: Path, config: SplatDecompConfig = SplatDecompConfig()
                      ) -> list[dict]:
    """Every scene's rows (module docstring) and the mean row; finished scenes are read back from
    ``cache/splat_decomp/rows_<key>.json``."""
    folder = Path(cache) / "splat_decomp"
    folder.mkdir(parents=True, exist_ok=True)
    scenes = decomp_scenes(config.size)
    rows = []
    for i, name in enumerate(config.scenes):
        done = folder / f"rows_{name}_{_key(config.key('scenes'), config.relight)}.json"
        if done.is_file():
            import json

            rows += json.loads(done.read_text())
            _log(config, f"[{i + 1}/{len(config.scenes)}] {name}: cached")
            continue
        _log(config, f"[{i + 1}/{len(config.scenes)}] {name}")
        scene_r = scene_rows(renderer, name, scenes[name], config, folder)
        save_json(done, scene_r)
        rows += scene_r
    return [table_row(r) for r in rows + [mean_row(rows)]] if rows else rows
