"""Writing a dataset: :func:`generate` (resumable, sharded over torchrun ranks) and one sample
(:func:`_write_sample`: scene, environment, targets, G-buffer inputs, ``meta.json``)."""
from __future__ import annotations

import json
import os
import shutil
from dataclasses import asdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

from viewer.imageio import write_exr
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

from ..reader import STDERR_FILE, DatasetError
from .config import (
    FORMAT,
    GeneratorConfig,
    check_config,
    split_of,
    target_settings,
    unoccluded_settings,
)
from .environments import random_environment
from .gbuffers import _AOVS, _gbuffer_geometry, _write_gbuffer
from .perturb import degrade_inputs
from .scenes import kind_scene
from .shapes import _mesh_files, _shape_files


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
    # a protocol dataset holds one configuration per split, each summarised on its own
    info_path = root / (f"dataset.{config.split}.json" if config.split else "dataset.json")
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
              if set(config.scene_kinds) & {"cluster", "concave", "gltf", "nested", "blocks"} else {})
    mine = [i for i in range(config.count) if shard_of(i, rank, world)]
    own = renderer is None
    renderer = renderer or Renderer()
    done = skipped = 0
    try:
        bar = tqdm(mine, desc="generate" + (f" [rank {rank}/{world}]" if world > 1 else ""),
                   unit="sample", disable=not progress)
        for i in bar:
            name = f"{i:06d}"
            final = root / split_of(i, config) / name
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
                       if not (root / split_of(i, config) / f"{i:06d}").is_dir()]
            if not missing:
                break
            if time.monotonic() > deadline:
                raise DatasetError(f"rank {rank}: {len(missing)} samples of other ranks still "
                                   f"missing after {wait_s:.0f} s (first: {missing[0]:06d})",
                                   where=root)
            time.sleep(1.0)
    return out


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
