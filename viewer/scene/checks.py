"""Checked values of scene files: the typed readers of one key (:func:`_num`, :func:`_vec`,
:func:`_int`, :func:`_str`, :func:`_path`, unknown keys :func:`_check_keys`), each a one-line
:class:`~viewer.errors.SceneError` naming the file and the key, and the ``[render]`` table's
validation (:func:`validate_render`), shared by scene files, ``Scene.with_render`` and the CLI.
The tables themselves become dataclasses in :mod:`viewer.scene.description`."""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

from ..errors import SceneError
from ..models import MODELS, SAMPLINGS
from ..neural.glsl import WEIGHT_STORAGES
from ..neural.shadow_net import SHADOW_NET_USES
from .settings import (
    AA_MODES,
    CONTACT_SHADOWS,
    ENV_SHADOWS_MAX,
    LOD_ERROR_MAX,
    RENDER_KEYS,
    SHADOW_BUDGET_MAX,
    SPLAT_DEPTHS,
    SSAA_MAX,
    RAY_SCALE_MAX,
    SSAO_SCALE_MAX,
)

TONEMAPS = ("pbr_neutral", "aces", "agx", "reinhard", "none")
BACKGROUNDS = ("environment", "transparent")
PRECISIONS = ("fp32", "fp16")
MIS_HEURISTICS = ("power", "balance")


def _check_keys(table: dict, allowed: set[str], where: str, file: str) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise SceneError(f"unknown key{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join(repr(k) for k in unknown)} in {where} "
                         f"(known: {', '.join(sorted(allowed))})", where=file)


def _num(v: Any, key: str, file: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise SceneError(f"{key} must be a finite number, got {v!r}", where=file)
    if not lo <= v <= hi:
        raise SceneError(f"{key} = {v} is outside [{lo}, {hi}]", where=file)
    return float(v)


def _vec(v: Any, n: int, key: str, file: str) -> tuple[float, ...]:
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise SceneError(f"{key} must be a list of {n} numbers, got {v!r}", where=file)
    return tuple(_num(x, key, file) for x in v)


def _int(v: Any, key: str, file: str, lo: int = 1, hi: int = 1 << 30) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise SceneError(f"{key} must be an integer in [{lo}, {hi}], got {v!r}", where=file)
    return v


def _str(v: Any, key: str, file: str, choices: tuple[str, ...] | None = None) -> str:
    if not isinstance(v, str):
        raise SceneError(f"{key} must be a string, got {v!r}", where=file)
    if choices is not None and v not in choices:
        raise SceneError(f"{key} = {v!r} is not one of {', '.join(choices)}", where=file)
    return v


def _path(v: Any, key: str, file: str, base: Path) -> str:
    s = _str(v, key, file)
    p = Path(os.path.expanduser(s))
    return str(p if p.is_absolute() else (base / p).resolve())


def validate_render(t: dict, file: str) -> dict[str, Any]:
    """The ``[render]`` keys of ``t`` checked (types, ranges, choices; paths resolved against
    ``file``'s folder): the one validation for scene files, ``Scene.with_render`` and the CLI."""
    _check_keys(t, set(RENDER_KEYS), "[render]", file)
    kw: dict[str, Any] = {}
    if "model" in t:
        kw["model"] = _str(t["model"], "render.model", file, tuple(MODELS))
    if "samples" in t:
        kw["samples"] = _int(t["samples"], "render.samples", file, 1, 1 << 20)
    if "sampling" in t:
        kw["sampling"] = _str(t["sampling"], "render.sampling", file, SAMPLINGS)
    for k in ("multiscatter", "ao", "specular_occlusion", "sun"):
        if k in t:
            if not isinstance(t[k], bool):
                raise SceneError(f"render.{k} must be true or false, got {t[k]!r}", where=file)
            kw[k] = t[k]
    if "tonemap" in t:
        kw["tonemap"] = _str(t["tonemap"], "render.tonemap", file, TONEMAPS)
    if "exposure" in t:
        kw["exposure"] = _num(t["exposure"], "render.exposure", file, -40.0, 40.0)
    if "background" in t:
        kw["background"] = _str(t["background"], "render.background", file, BACKGROUNDS)
    if "aa" in t:
        kw["aa"] = _str(t["aa"], "render.aa", file, AA_MODES)
    if "ssaa" in t:
        kw["ssaa"] = _int(t["ssaa"], "render.ssaa", file, 1, SSAA_MAX)
    if "seed" in t:
        kw["seed"] = _int(t["seed"], "render.seed", file, 0, (1 << 31) - 1)
    if "specialize" in t:
        if not isinstance(t["specialize"], bool):
            raise SceneError(f"render.specialize must be true or false, got {t['specialize']!r}",
                             where=file)
        kw["specialize"] = t["specialize"]
    if "precision" in t:
        kw["precision"] = _str(t["precision"], "render.precision", file, PRECISIONS)
    if "max_depth" in t:
        kw["max_depth"] = _int(t["max_depth"], "render.max_depth", file, 2, 64)
    if "mis_heuristic" in t:
        kw["mis_heuristic"] = _str(t["mis_heuristic"], "render.mis_heuristic", file,
                                   MIS_HEURISTICS)
    if "raytrace_rays" in t:
        kw["raytrace_rays"] = _int(t["raytrace_rays"], "render.raytrace_rays", file, 1, 64)
    if "ray_frames" in t:
        kw["ray_frames"] = _int(t["ray_frames"], "render.ray_frames", file, 1,
                                     4096)
    if "ray_scale" in t:
        kw["ray_scale"] = _int(t["ray_scale"], "render.ray_scale", file, 1, RAY_SCALE_MAX)
    if "ray_still_frames" in t:
        kw["ray_still_frames"] = _int(t["ray_still_frames"], "render.ray_still_frames", file, 1,
                                      4096)
    for k in ("ssao", "indirect", "shadows", "ssao_blur", "indirect_blur", "raytrace",
              "ray_denoise"):
        if k in t:
            if not isinstance(t[k], bool):
                raise SceneError(f"render.{k} must be true or false, got {t[k]!r}", where=file)
            kw[k] = t[k]
    if "ssao_rays" in t:
        kw["ssao_rays"] = _int(t["ssao_rays"], "render.ssao_rays", file, 1, 1024)
    if "ssao_steps" in t:
        kw["ssao_steps"] = _int(t["ssao_steps"], "render.ssao_steps", file, 1, 256)
    if "ssao_scale" in t:
        kw["ssao_scale"] = _int(t["ssao_scale"], "render.ssao_scale", file, 1, SSAO_SCALE_MAX)
    for k in ("ssao_radius", "ssao_thickness"):
        if k in t:
            kw[k] = _num(t[k], f"render.{k}", file, 1e-6, 1e6)
    if "shadow_size" in t:
        kw["shadow_size"] = _int(t["shadow_size"], "render.shadow_size", file, 64, 8192)
    if "env_shadows" in t:
        kw["env_shadows"] = _int(t["env_shadows"], "render.env_shadows", file, 0, ENV_SHADOWS_MAX)
    if "shadow_cube_size" in t:
        kw["shadow_cube_size"] = _int(t["shadow_cube_size"], "render.shadow_cube_size", file, 32,
                                      4096)
    if "shadow_budget" in t:
        v = _num(t["shadow_budget"], "render.shadow_budget", file, 0.0, SHADOW_BUDGET_MAX)
        if 0.0 < v < 1.0:
            raise SceneError(f"render.shadow_budget = {v!r} is below 1 map (0: no limit)",
                             where=file)
        kw["shadow_budget"] = v
    if "shadow_cascades" in t:
        v = t["shadow_cascades"]
        if v != "auto" and (isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 4):
            raise SceneError(f'render.shadow_cascades = {v!r} is not one of "auto", 1, 2, 3, 4',
                             where=file)
        kw["shadow_cascades"] = v
    for k in ("shadow_softness", "shadow_bias"):
        if k in t:
            kw[k] = _num(t[k], f"render.{k}", file, 0.0, 100.0)
    if "shadow_proxy_snap" in t:
        kw["shadow_proxy_snap"] = _num(t["shadow_proxy_snap"], "render.shadow_proxy_snap", file,
                                       0.0, 1.0)
    if "shadow_lod_error" in t:
        kw["shadow_lod_error"] = _num(t["shadow_lod_error"], "render.shadow_lod_error", file,
                                      0.0, LOD_ERROR_MAX)
    if "contact_shadows" in t:
        kw["contact_shadows"] = _str(t["contact_shadows"], "render.contact_shadows", file,
                                     CONTACT_SHADOWS)
    if "contact_length" in t:
        kw["contact_length"] = _num(t["contact_length"], "render.contact_length", file, 1e-6, 1e6)
    if "splat_depth" in t:
        kw["splat_depth"] = _str(t["splat_depth"], "render.splat_depth", file, SPLAT_DEPTHS)
    if "neural_storage" in t:
        kw["neural_storage"] = _str(t["neural_storage"], "render.neural_storage", file,
                                    WEIGHT_STORAGES)
    if "shadow_net_use" in t:
        kw["shadow_net_use"] = _str(t["shadow_net_use"], "render.shadow_net_use", file,
                                    SHADOW_NET_USES)
    for k in ("weights", "teacher_weights", "shadow_net"):  # relative to the scene file
        if k in t:
            base = Path(file).resolve().parent if Path(file).is_file() else Path.cwd()
            kw[k] = _path(t[k], f"render.{k}", file, base)
    return kw
