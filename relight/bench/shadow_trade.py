"""The shadow estimator's trade against truth (issue 38): every visibility option of a
rasterised frame beside the others, each with its accuracy on a protocol dataset's split and its
cost in one run.

Options (:data:`OPTIONS`, all ``ggx_split_sum`` with the indirect light and the shadow maps):
SSAO alone (contact shadows off), SSAO with screen-space contact shadows, SSAO with the
one-bounce light through the bilateral blur (``indirect_blur``), SSAO times the neural
shadow estimator (a weights file), and the ray-traced tier (meshes, and splats as their opaque
cores; a G-buffer stack has no geometry off-screen to trace).

Accuracy: the protocol's metric (:func:`learned.protocol.scores.psnr`: Reinhard-mapped, over each
sample's foreground) of the option's frame against the split's path-traced targets, the mean over
the samples and its paired difference to the first option (95 % bootstrap over the samples,
:func:`learned.protocol.scores.paired_bootstrap`). Frames are drawn from the samples' stacks,
meshes or those meshes tiled with splats of their true materials (``geometry``,
:func:`learned.data.scene.geometry_scene`; the splat frames' G-buffer comes from the viewer's
splat pass). Validation splits only by
default: scoring ``test`` appends to the dataset's ledger like every test scoring.

Cost: each option's whole frame against the first option's at ``size`` on the bench's mesh scene
(the demo; or any scene; for ``splat`` the demo tiled with splats at that size,
:func:`cost_scene`), in alternating blocks (:func:`relight.bench.timing.time_pair`): the ratio of
their medians in one run is the number to quote; milliseconds on a shared CPU are noise.

``python -m relight.bench.shadow_trade DATA WEIGHTS [--split val] [--geometry mesh|splat]
[--out DIR]``
writes ``shadow_trade.json`` and ``shadow_trade.md``.
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np
import torch

SIZE = (512, 512)
BASE = {"model": "ggx_split_sum", "ssao": True, "indirect": True, "raytrace": False}
# name -> render settings over BASE ({weights}: the estimator's file)
OPTIONS = {
    "SSAO": {"contact_shadows": "off"},
    "SSAO + contact shadows": {"contact_shadows": "on"},
    "SSAO, blurred bounce": {"contact_shadows": "off", "indirect_blur": True},
    "SSAO x shadow estimator": {"contact_shadows": "off", "shadow_net": "{weights}"},
    "ray-traced tier": {"raytrace": True, "ssao": False, "indirect": False},
}


def option_settings(name: str, weights: str) -> dict:
    """The render settings of option ``name`` (:data:`OPTIONS`) with ``weights`` filled in."""
    return BASE | {k: (v.format(weights=weights) if isinstance(v, str) else v)
                   for k, v in OPTIONS[name].items()}


def options(geometry: str) -> list[str]:
    """The options of :data:`OPTIONS` that ``geometry`` can draw: the rays need geometry (meshes,
    or splats' opaque cores: :mod:`viewer.raytrace.splat_proxies`), which a stack has not."""
    return [n for n in OPTIONS if geometry != "stack" or n != "ray-traced tier"]


def accuracy(data: str, split: str, weights: str, geometry: str = "stack",
             renderer=None) -> dict:
    """Option name -> per-sample protocol PSNR on ``split`` (the rays option not for stacks:
    :func:`options`)."""
    from learned.data.reader import list_samples, load_sample
    from learned.data.scene import geometry_scene
    from learned.protocol.scores import psnr
    from viewer.renderer import Renderer

    own = renderer is None
    renderer = renderer or Renderer()
    names = options(geometry)
    out: dict[str, list[float]] = {n: [] for n in names}
    try:
        for folder in list_samples(data, split):
            sample = load_sample(folder)
            fg = torch.from_numpy(sample.foreground())
            target = torch.from_numpy(np.ascontiguousarray(sample.target))[fg]
            for n in names:
                scene = geometry_scene(sample, geometry, **option_settings(n, weights))
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # e.g. the rays' skipped settings
                    frame = renderer.render(scene).radiance[..., :3]
                out[n].append(psnr(torch.from_numpy(np.ascontiguousarray(frame))[fg], target))
    finally:
        if own:
            renderer.release()
    return out


def cost(renderer, scene, weights: str, config, names=tuple(OPTIONS), size=SIZE) -> dict:
    """Option name -> (its frame's median ms, the first option's in the same blocks), for the
    options ``names``."""
    from .timing import time_pair

    base = scene.with_camera(size=size).with_render(**option_settings("SSAO", weights))
    out = {}
    for n in names:
        other = scene.with_camera(size=size).with_render(**option_settings(n, weights))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            (ms, _), (base_ms, _) = time_pair(renderer, other, base, size, config)
        out[n] = (ms, base_ms)
    return out


def cost_scene(geometry: str, folder: Path, size=SIZE):
    """The scene the options are timed on: the bench's demo, or (``splat``) the demo's surfaces
    tiled with splats as its camera sees them at ``size``
    (:func:`learned.data.splat_tiling.scene_splats`), written to ``folder/demo_splats.ply``."""
    import dataclasses

    from learned.data.splat_tiling import scene_splats
    from viewer.scene.description import ObjectSpec
    from viewer.splats.ply import write_ply

    from .scenes import demo_scene

    scene = demo_scene()
    if geometry != "splat":
        return scene
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "demo_splats.ply"
    write_ply(path, scene_splats(scene.with_camera(size=size)))
    return dataclasses.replace(scene, objects=(ObjectSpec("splats", path=str(path)),))


def trade_rows(scores: dict, costs: dict | None) -> list[dict]:
    """One row per option: mean PSNR, its paired difference to the first option with the
    interval, and the cost ratio (None without ``costs``)."""
    from learned.protocol.scores import paired_bootstrap

    first = np.array(next(iter(scores.values())))
    rows = []
    for n, v in scores.items():
        d = paired_bootstrap(np.array(v) - first, over_seeds=False)
        row = {"option": n, "psnr": float(np.mean(v)), "vs_ssao": d["mean"],
               "vs_ssao_lo": d["lo"], "vs_ssao_hi": d["hi"], "samples": len(v)}
        if costs is not None and n in costs:
            ms, base_ms = costs[n]
            row |= {"frame_ms": ms, "ssao_frame_ms": base_ms, "ratio_frame": ms / base_ms}
        rows.append(row)
    return rows


def markdown(rows: list[dict], header: str) -> str:
    lines = [header, "", "| option | PSNR dB | − SSAO [95 %] | frame / SSAO's frame |",
             "|---|---|---|---|"]
    for r in rows:
        ratio = f"{r['ratio_frame']:.2f}" if "ratio_frame" in r else "–"
        lines.append(f"| {r['option']} | {r['psnr']:.2f} | {r['vs_ssao']:+.2f} "
                     f"[{r['vs_ssao_lo']:+.2f}, {r['vs_ssao_hi']:+.2f}] | {ratio} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m relight.bench.shadow_trade")
    p.add_argument("data", help="a protocol dataset (relight data OUT --protocol)")
    p.add_argument("weights", help="the shadow estimator's weights file")
    p.add_argument("--split", default="val", choices=("val", "test"))
    p.add_argument("--geometry", default="stack", choices=("stack", "mesh", "splat"))
    p.add_argument("--out", default="runs/shadow_trade")
    p.add_argument("--no-cost", action="store_true", help="accuracy only")
    a = p.parse_args(argv)
    a.weights = str(Path(a.weights).resolve())  # scenes resolve relative paths from their file
    from viewer.errors import RelightError
    from viewer.renderer import Renderer

    from .run import BenchConfig

    renderer = Renderer()
    out = Path(a.out)
    try:
        scores = accuracy(a.data, a.split, a.weights, a.geometry, renderer)
        costs = None if a.no_cost else cost(renderer, cost_scene(a.geometry, out), a.weights,
                                            BenchConfig(), options(a.geometry))
    except RelightError as exc:
        print(f"{p.prog}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    finally:
        renderer.release()
    rows = trade_rows(scores, costs)
    if a.split == "test":
        from learned.protocol.data import dataset_hash
        from learned.protocol.scores import record_test

        record_test(a.data, f"shadow trade ({a.geometry})", [a.weights],
                    len(next(iter(scores.values()))), dataset_hash(a.data, ("test",)))
    out.mkdir(parents=True, exist_ok=True)
    cmd = "python -m relight.bench.shadow_trade " + " ".join(argv or sys.argv[1:])
    (out / "shadow_trade.json").write_text(json.dumps(
        {"command": cmd, "split": a.split, "geometry": a.geometry, "rows": rows,
         "per_sample": scores}, indent=1) + "\n")
    (out / "shadow_trade.md").write_text(markdown(rows, f"`{cmd}`"))
    print(markdown(rows, f"`{cmd}`"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
