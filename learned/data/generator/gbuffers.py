"""Image G-buffers as geometry: a sample's G-buffer read from a file or rendered from a random
scene, its materials perturbed (:func:`_gbuffer_geometry`), and G-buffer channels written as an
FFHQ256-PBR folder (:func:`_write_gbuffer`)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from viewer.geometry.imagespace import load_ffhq_pbr, load_stack_exr

from .config import GeneratorConfig
from .perturb import perturb_materials
from .scenes import random_scene


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
