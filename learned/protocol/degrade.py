"""Degraded G-buffers: the inputs of relighting *estimated* scenes (the thesis's setting), made
from a clean dataset's true ones at a ``level`` in [0, 1] (0: the true G-buffer).

The degradation model (every error scales with ``level``; drawn from the sample's own streams
``default_rng([seed, index, 2])`` and ``[seed, index, 3]``, so a level's inputs are the same for
every model and every run):

=========  =====================================================================================
normals    :func:`~learned.data.generator.degrade_inputs`: a smooth random field (amplitude
           0.15-0.35 x level) and per-pixel Gaussian noise (0.03-0.12 x level), renormalised;
           then quantised to ``bits`` per component (encoded n * 0.5 + 0.5)
albedo     ``degrade_inputs``: shading baked in (times the blurred luminance of the unoccluded
           render to the power 0.3-0.8 x level); then a global scale (1 +- 0.3 x level: the
           scale ambiguity of intrinsic decomposition), a Gaussian blur (sigma 2 x level px),
           per-pixel noise (sigma 0.05 x level), clipped to [0, 1] and quantised
roughness  ``degrade_inputs``: r * (1 +- 0.4 level) + (-0.1..0.15) level; then blurred (sigma
           2 x level px), per-pixel noise (sigma 0.05 x level), clipped to [0.02, 1], quantised
metallic   blurred (sigma 2 x level px: soft edges), a bias towards 0.5 (metals read as less
           metallic and dielectrics as more, by 0.3 x level), per-pixel noise (0.1 x level),
           clipped to [0, 1], quantised
depth      a relative scale error (1 +- 0.1 x level), a smooth relative field (+- 0.05 x level)
           and per-pixel relative noise (sigma 0.01 x level): what the screen-space passes (SSAO,
           its visibility S(x), the indirect light) read
=========  =====================================================================================

``bits`` = 8 - round(8 x level), at least 3 (level 0.25: 6 bits, 0.5: 4 bits). The specular
level, the material AO (1 in path-traced data) and the mask stay true; the targets (``rgb``,
``rgb_unoccluded``) stay those of the true scene. :func:`degraded_dataset` writes the degraded
copy of a dataset once under ``ROOT/_degraded/<level>/`` (resumable, sample by sample) and
returns its root, in the same layout as the clean one.
"""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np

from viewer.imageio import write_exr

from ..data.generator import degrade_inputs
from ..data.generator.gbuffers import _write_gbuffer
from ..data.generator.perturb import _masked_blur, _smooth_field
from ..data.reader import SPLITS, UNOCCLUDED_FILE, DatasetError, list_samples, load_sample

LEVELS = (0.0, 0.25, 0.5)  # the levels of the protocol's measurements
# the files of a sample copied unchanged into its degraded copy (targets and lighting)
KEPT_FILES = ("rgb.exr", UNOCCLUDED_FILE, "rgb_stderr.exr", "env.exr", "env.hdr")


def quantise(x: np.ndarray, bits: int) -> np.ndarray:
    """``x`` in [0, 1] rounded to ``2**bits`` levels."""
    q = float(2 ** bits - 1)
    return np.round(np.clip(x, 0.0, 1.0) * q) / q


def level_bits(level: float) -> int:
    return max(3, 8 - int(round(8 * float(level))))


def estimate_errors(channels: dict, radiance: np.ndarray, seed: int, index: int,
                    level: float) -> tuple[dict, dict]:
    """The G-buffer ``channels`` (channel -> ``[H, W, C]``, the renderer's AOV names) degraded at
    ``level`` (module docstring) and the recipe; ``radiance`` ``[H, W, 3]`` the unoccluded render
    (whose shading the albedo bakes in). Level 0 returns the channels unchanged."""
    s = float(level)
    if not 0.0 <= s <= 1.0:
        raise ValueError(f"degradation level {level} is not in [0, 1]")
    if s == 0.0:
        return dict(channels), {"level": 0.0}
    out, recipe = degrade_inputs(channels, radiance, np.random.default_rng([seed, index, 2]), s)
    rng = np.random.default_rng([seed, index, 3])
    fg2 = channels["alpha"][..., 0] > 0.0
    fg = fg2[..., None]
    size = channels["albedo"].shape[0]
    bits = level_bits(s)
    sigma = 2.0 * s

    def blur(x):
        return _masked_blur(x, fg2, sigma).astype(np.float32) if sigma > 0.3 else x

    def noise(x, amp):
        return x + amp * rng.standard_normal(x.shape).astype(np.float32)

    scale = 1.0 + s * float(rng.uniform(-0.3, 0.3))
    albedo = quantise(noise(blur(out["albedo"] * scale), 0.05 * s), bits)
    rough = quantise(np.clip(noise(blur(out["roughness"]), 0.05 * s), 0.02, 1.0), bits)
    rough = np.maximum(rough, 0.02)
    metal = blur(channels["metallic"])
    metal = quantise(noise(metal + 0.3 * s * (0.5 - metal) * 2.0, 0.1 * s), bits)
    n = quantise(out["normal"] * 0.5 + 0.5, bits) * 2.0 - 1.0
    n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-6)
    depth_scale = 1.0 + s * float(rng.uniform(-0.1, 0.1))
    field = (_smooth_field(rng, size, int(rng.integers(3, 9))) * 2.0 - 1.0) * 0.05 * s
    depth = channels["depth"] * (depth_scale + field[..., :1])
    depth = depth * (1.0 + 0.01 * s * rng.standard_normal(depth.shape).astype(np.float32))
    for name, value in (("albedo", albedo), ("roughness", rough), ("metallic", metal),
                        ("normal", n), ("depth", depth)):
        out[name] = np.where(fg, value, channels[name]).astype(np.float32)
    recipe = {"level": s, "bits": bits, "blur_sigma_px": sigma,
              "albedo_scale": scale, "depth_scale": depth_scale, "inputs": recipe}
    return out, recipe


def _gbuffer_channels(sample) -> dict:
    """A loaded sample's G-buffer under the renderer's AOV names (``alpha`` = the mask)."""
    return {k: np.ascontiguousarray(v) for k, v in sample.channels.items()}


def degraded_dataset(root, level: float, splits=SPLITS, progress: bool = False) -> Path:
    """The dataset ``root`` with every sample's G-buffer degraded at ``level`` (module
    docstring), written once under ``root/_degraded/<level>/`` (a finished sample is a folder;
    one being written is ``<name>.tmp`` and is redone); ``root`` itself for level 0."""
    root = Path(root)
    if float(level) == 0.0:
        return root
    out_root = root / "_degraded" / f"{float(level):g}"
    for split in splits:
        if not (root / split).is_dir():
            continue
        folders = list_samples(root, split)
        if progress:
            from tqdm import tqdm

            folders = tqdm(folders, desc=f"degrade {split} {level:g}", unit="sample")
        for folder in folders:
            final = out_root / split / folder.name
            if final.is_dir():
                continue
            _degrade_sample(folder, final, float(level))
    return out_root


def _degrade_sample(folder: Path, final: Path, level: float) -> None:
    sample = load_sample(folder)
    meta_path = folder / "meta.json"
    meta = json.loads(meta_path.read_text()) if meta_path.is_file() else {}
    if "index" not in meta or "seed" not in meta:
        raise DatasetError("meta.json has no index and seed: the degradation's random streams "
                           "need them", where=folder)
    if sample.unoccluded is None:
        raise DatasetError(f"no {UNOCCLUDED_FILE} (the shading the degraded albedo bakes in)",
                           where=folder)
    ch = _gbuffer_channels(sample)
    degraded, recipe = estimate_errors(ch, sample.unoccluded, int(meta["seed"]),
                                       int(meta["index"]), level)
    # a folder of this process's own: two trainings writing the same copy at once (each sample
    # is seeded, so both write the same files) would otherwise share, and break, one folder
    tmp = final.with_name(f"{final.name}.{os.getpid()}.tmp")  # list_samples skips *.tmp
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    _write_gbuffer(tmp, degraded, sample.fov_y, write_exr)
    for name in KEPT_FILES:
        if (folder / name).is_file():
            shutil.copyfile(folder / name, tmp / name)
    meta["degrade"] = recipe
    (tmp / "meta.json").write_text(json.dumps(meta, indent=1))
    try:
        os.replace(tmp, final)
    except OSError:
        if not final.is_dir():
            raise
        shutil.rmtree(tmp)  # another process finished the same sample first


__all__ = ["LEVELS", "degraded_dataset", "estimate_errors", "level_bits", "quantise"]
