"""Reader for datasets in the FFHQ256-PBR layout (thesis sec. 4.3.2).

A dataset is a folder with one sub-folder per split (``train``, ``val``, ``test``) holding one
folder per sample; a sample folder is exactly what :func:`viewer.geometry.imagespace.load_ffhq_pbr`
reads (its docstring table is the layout: rgb, albedo, normal, roughness, specular, metallic, depth,
ao, mask images as PNG/EXR, ``env.exr|hdr``, ``camera.json``). For training a sample must also
have its target ``rgb`` and its environment ``env``; ``rgb_unoccluded.exr`` (optional, written by
the generator) is the same target without occlusion, the teacher's phase-1 target;
``rgb_stderr.exr`` (optional) the per-pixel standard error of a path-traced target (``relight
reference``), and ``meta.json``'s ``target.source`` says what made the target (``rasteriser`` or
``reference``).
``dataset.json`` at the root (written by the generator, optional for user data) summarises how it
was made.

Every problem is a one-line :class:`DatasetError` naming the file or folder.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from viewer.errors import InputError
from viewer.geometry.imagespace import load_ffhq_pbr, view_dirs_cs
from viewer.imageio import read_image

SPLITS = ("train", "val", "test")
UNOCCLUDED_FILE = "rgb_unoccluded.exr"  # the target without occlusion (learned.data.generator)
STDERR_FILE = "rgb_stderr.exr"  # the standard error of a path-traced target, per pixel


class DatasetError(InputError):
    """A dataset folder or sample that cannot be used for training or evaluation."""


@dataclass
class Sample:
    name: str
    folder: Path
    channels: dict  # G-buffer channel -> [H, W, C] float32 (camera space = world space)
    target: np.ndarray  # [H, W, 3] linear RGB
    environment: Path  # the HDR environment that lit the target
    fov_y: float  # degrees
    unoccluded: np.ndarray | None = None  # [H, W, 3] linear RGB without AO/SSAO/indirect, if any
    target_stderr: np.ndarray | None = None  # [H, W, 3] standard error of a path-traced target
    target_source: str | None = None  # meta.json target.source: "rasteriser" | "reference"
    kind: str | None = None  # meta.json geometry.kind (the generator's scene kind), if recorded
    # meta.json environment.source (the HDR file or procedural sky the sample was lit by), if any
    environment_source: str | None = None

    @property
    def size(self) -> tuple[int, int]:
        h, w = self.target.shape[:2]
        return w, h

    def view_dirs(self) -> np.ndarray:
        """``[H, W, 3]`` unit directions from the camera (origin, looking down -Z) through pixels."""

        return view_dirs_cs(*self.size, self.fov_y)

    def foreground(self) -> np.ndarray:
        """``[H, W]`` bool: mask >= 0.5."""
        return self.channels["alpha"][..., 0] > 0.0


def load_sample(folder: str | os.PathLike, require_target: bool = True) -> Sample:
    """One sample folder; the G-buffer through the viewer's FFHQ256-PBR loader."""
    folder = Path(folder)
    gb = load_ffhq_pbr(folder)  # InputError naming the file for missing/mismatched channels
    if gb.target is None and require_target:
        raise DatasetError("missing the target image rgb (png/jpg/exr/hdr)", where=folder)
    if gb.environment is None:
        raise DatasetError("missing the environment env (exr/hdr)", where=folder)
    target = gb.target[..., :3] if gb.target is not None else None
    extra = {}
    for key, file in (("unoccluded", UNOCCLUDED_FILE), ("target_stderr", STDERR_FILE)):
        if not (folder / file).is_file():
            continue
        image, _ = read_image(folder / file, (3, 4))
        if target is not None and image.shape[:2] != target.shape[:2]:
            raise DatasetError(f"{file} is {image.shape[1]}x{image.shape[0]}, "
                               f"rgb {target.shape[1]}x{target.shape[0]}", where=folder)
        extra[key] = np.ascontiguousarray(image[..., :3])
    meta = folder / "meta.json"
    if meta.is_file():
        try:
            info = json.loads(meta.read_text())
            target_info = info.get("target", {})
            geometry = info.get("geometry", {})
            environment = info.get("environment", {})
        except (ValueError, AttributeError) as exc:
            raise DatasetError(f"not valid JSON ({exc})", where=meta) from None
        if isinstance(geometry, dict) and geometry.get("kind") is not None:
            extra["kind"] = str(geometry["kind"])
        if isinstance(environment, dict) and environment.get("source") is not None:
            extra["environment_source"] = str(environment["source"])
        # samples generated before path-traced targets came from the rasteriser
        extra["target_source"] = str(target_info.get("source", "rasteriser"))
    return Sample(name=folder.name, folder=folder, channels=gb.channels, target=target,
                  environment=Path(gb.environment), fov_y=float(gb.fov_y), **extra)


def list_samples(root: str | os.PathLike, split: str) -> list[Path]:
    """Sample folders of ``split`` under ``root``, sorted by name (unfinished ``*.tmp`` skipped)."""
    root = Path(root)
    if split not in SPLITS:
        raise DatasetError(f"unknown split {split!r} (known: {', '.join(SPLITS)})", where=root)
    if not root.is_dir():
        raise DatasetError("dataset folder not found", where=root)
    folder = root / split
    if not folder.is_dir():
        raise DatasetError(f"no {split!r} split folder", where=root)
    return sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.endswith(".tmp"))


def summary(root: str | os.PathLike) -> dict:
    """Sample counts per split and the generator's ``dataset.json`` (if any)."""
    root = Path(root)
    out = {"root": str(root)}
    for split in SPLITS:
        out[split] = len(list_samples(root, split)) if (root / split).is_dir() else 0
    info = root / "dataset.json"
    if info.is_file():
        try:
            out["generator"] = json.loads(info.read_text())
        except ValueError as exc:
            raise DatasetError(f"not valid JSON ({exc})", where=info) from None
    return out
