"""The shadow estimator's trade against truth (issue 38): every visibility option of a
rasterised frame beside the others, each with its accuracy on a protocol dataset's split and its
cost in one run.

Options (:data:`OPTIONS`, all ``ggx_split_sum`` with the indirect light and the shadow maps):
SSAO alone (contact shadows off), SSAO with screen-space contact shadows, SSAO with the
one-bounce light through the bilateral blur (``indirect_blur``), SSAO times the neural
shadow estimator (a weights file), and the ray-traced tier with 1, 2, 4 and 8 frames of rays
(``ray_still_frames``: 1 is what one interactive frame traces, 8 a headless render's default)
and with 1 frame of rays for one pixel in 2 x 2 (``ray_scale``; meshes, and splats as their
Gaussians; a G-buffer stack has no geometry off-screen to trace).

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

Equal time and equal accuracy (:func:`matched`): the rays' points make a curve of accuracy
against cost; every other option is read against it - the rays' PSNR at the option's cost
(interpolated in log cost; none when the option costs less than one frame of rays) and the cost
at which the rays reach the option's PSNR (at most one frame's when the first frame already
does). ``shadow_trade.png`` draws the options and the curve.

``python -m relight.bench.shadow_trade DATA WEIGHTS [--split val] [--geometry mesh|splat]
[--out DIR]``
writes ``shadow_trade.json``, ``shadow_trade.md`` and ``shadow_trade.png``; ``relight bench --suite
shadow_trade --trade DATA`` measures meshes, stacks and splats with the shipped files.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np
import torch

SIZE = (512, 512)
BASE = {"model": "ggx_split_sum", "ssao": True, "indirect": True, "raytrace": False}
# the points of the rays' curve of accuracy against cost: (frames of rays a headless frame
# accumulates, ``ray_still_frames``: one is what an interactive frame traces, 8 the headless
# default; ``ray_scale``: rays for one pixel in k x k)
RAY_POINTS = ((1, 2), (1, 1), (2, 1), (4, 1), (8, 1))


def ray_option(frames: int, scale: int = 1) -> str:
    return (f"ray-traced tier, {frames} frame{'s' if frames > 1 else ''}"
            + (f", ray_scale {scale}" if scale > 1 else ""))


# name -> render settings over BASE ({weights}: the estimator's file)
OPTIONS = {
    "SSAO": {"contact_shadows": "off"},
    "SSAO + contact shadows": {"contact_shadows": "on"},
    "SSAO, blurred bounce": {"contact_shadows": "off", "indirect_blur": True},
    "SSAO x shadow estimator": {"contact_shadows": "off", "shadow_net": "{weights}"},
    **{ray_option(n, k): {"raytrace": True, "ssao": False, "indirect": False,
                          "ray_still_frames": n, "ray_scale": k} for n, k in RAY_POINTS},
}
RAY_OPTIONS = tuple(ray_option(n, k) for n, k in RAY_POINTS)


def option_settings(name: str, weights: str) -> dict:
    """The render settings of option ``name`` (:data:`OPTIONS`) with ``weights`` filled in."""
    return BASE | {k: (v.format(weights=weights) if isinstance(v, str) else v)
                   for k, v in OPTIONS[name].items()}


def options(geometry: str) -> list[str]:
    """The options of :data:`OPTIONS` that ``geometry`` can draw: the rays need geometry (meshes,
    or splats' proxies: :mod:`viewer.raytrace.splat_proxies`), which a stack has not."""
    return [n for n in OPTIONS if geometry != "stack" or n not in RAY_OPTIONS]


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


def _log_interp(x: float, x0: float, x1: float, y0: float, y1: float) -> float:
    """``y`` at ``x`` on the line through (log x0, y0) and (log x1, y1)."""
    if x1 == x0:
        return y0
    t = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
    return y0 + t * (y1 - y0)


def matched(rows: list[dict]) -> None:
    """Adds to every timed row that is not the rays' its equal-time and equal-accuracy readings
    of the rays' curve (module doc), in place: ``rays_psnr_equal_time`` (None when it costs less
    than one frame of rays) and ``rays_ratio_equal_psnr`` with ``rays_ratio_bound`` (``"="``
    interpolated, ``"<="`` the first frame already reaches it, None when no ray point does);
    an option dearer than the dearest ray point reads that point's PSNR."""
    rays = sorted(((r["ratio_frame"], r["psnr"]) for r in rows
                   if r["option"] in RAY_OPTIONS and "ratio_frame" in r))
    if not rays:
        return
    for r in rows:
        if r["option"] in RAY_OPTIONS or "ratio_frame" not in r:
            continue
        c, q = r["ratio_frame"], r["psnr"]
        at_time = None
        if c >= rays[0][0]:
            at_time = rays[-1][1]
            for (c0, q0), (c1, q1) in zip(rays, rays[1:]):
                if c0 <= c <= c1:
                    at_time = _log_interp(c, c0, c1, q0, q1)
                    break
        cost_at, bound = None, None
        if rays[0][1] >= q:
            cost_at, bound = rays[0][0], "<="
        else:
            for (c0, q0), (c1, q1) in zip(rays, rays[1:]):
                if q0 < q <= q1:  # the first crossing along growing cost
                    t = (q - q0) / (q1 - q0)
                    cost_at = math.exp(math.log(c0) + t * (math.log(c1) - math.log(c0)))
                    bound = "="
                    break
        r |= {"rays_psnr_equal_time": at_time, "rays_ratio_equal_psnr": cost_at,
              "rays_ratio_bound": bound}


def markdown(rows: list[dict], header: str) -> str:
    cols = "| option | PSNR dB | − SSAO [95 %] | frame / SSAO's frame |"
    readings = any("rays_ratio_bound" in r for r in rows)
    if readings:
        cols += " rays at equal time: PSNR dB | rays at equal PSNR: frame / SSAO's |"
    lines = [header, "", cols, "|---|---|---|---|" + ("---|---|" if readings else "")]
    for r in rows:
        ratio = f"{r['ratio_frame']:.2f}" if "ratio_frame" in r else "–"
        line = (f"| {r['option']} | {r['psnr']:.2f} | {r['vs_ssao']:+.2f} "
                f"[{r['vs_ssao_lo']:+.2f}, {r['vs_ssao_hi']:+.2f}] | {ratio} |")
        if readings:
            if "rays_ratio_bound" not in r:
                line += " | |"
            else:
                t = r["rays_psnr_equal_time"]
                line += " " + ("– (cheaper than one frame of rays)" if t is None
                               else f"{t:.2f}") + " |"
                c, b = r["rays_ratio_equal_psnr"], r["rays_ratio_bound"]
                line += " " + ("– (no ray point reaches it)" if c is None
                               else f"{'≤ ' if b == '<=' else ''}{c:.2f}") + " |"
        lines.append(line)
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], path: Path, title: str) -> bool:
    """``shadow_trade.png``: PSNR against the frame's cost relative to SSAO's (log), each option
    a point, the rays' frames joined; False (nothing written) without matplotlib or costs."""
    timed = [r for r in rows if "ratio_frame" in r]
    if not timed:
        return False
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig, ax = plt.subplots(figsize=(6.5, 4.5), dpi=110)
    rays = sorted((r for r in timed if r["option"] in RAY_OPTIONS),
                  key=lambda r: r["ratio_frame"])
    if rays:
        ax.plot([r["ratio_frame"] for r in rays], [r["psnr"] for r in rays], "o-", color="k",
                label="ray-traced tier (frames; ray_scale)")
        for r in rays:
            ax.annotate(", ".join(r["option"].split(", ")[1:]), (r["ratio_frame"], r["psnr"]),
                        textcoords="offset points", xytext=(4, -10), fontsize=7)
    for i, r in enumerate(x for x in timed if x["option"] not in RAY_OPTIONS):
        ax.errorbar([r["ratio_frame"]], [r["psnr"]], fmt="s", color=plt.cm.tab10(i),
                    label=r["option"])
    ax.set_xscale("log")
    from matplotlib.ticker import FuncFormatter

    # ticks as 1, 2, 3, 5, 10 rather than 2 x 10^0
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if f"{v:g}"[0] in "1235"
                                               else ""))
    ax.set_xlabel("frame / SSAO's frame (log)")
    ax.set_ylabel("PSNR against path-traced truth (dB)")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True


SHIPPED = {"mesh": "shadow_net_mesh.safetensors", "splat": "shadow_net_mesh.safetensors",
           "stack": "shadow_net.safetensors"}  # the estimator each geometry is scored with


def suite_rows(renderer, datasets, config, folder: Path, progress: bool = True) -> list[dict]:
    """``relight bench --suite shadow_trade --trade DATA``: the trade on each dataset's val split
    for meshes, stacks and (not ``--quick``: minutes of splat frames) splats, with the shipped
    estimator of each (:data:`SHIPPED`), timed at 512^2 in the same run, read at equal time and
    equal accuracy; each geometry's plot ``folder/<dataset>_<geometry>.png``."""
    from assets import ASSET_ROOT
    from viewer.errors import RelightError

    import time

    rows = []
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()

    def log(message):
        if progress:
            print(f"shadow_trade: {message} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr,
                  flush=True)

    for data in datasets:
        for geometry in ("mesh", "stack") if config.quick else ("mesh", "stack", "splat"):
            weights = ASSET_ROOT / "weights" / SHIPPED[geometry]
            if not weights.is_file():
                raise RelightError("the shipped estimator is missing", where=weights)
            log(f"{data}, {geometry}: scoring {len(options(geometry))} options on val")
            scores = accuracy(data, "val", str(weights), geometry, renderer)
            log(f"{data}, {geometry}: timing them at {SIZE[0]}x{SIZE[1]}")
            costs = cost(renderer, cost_scene(geometry, folder), str(weights), config,
                         options(geometry))
            found = trade_rows(scores, costs)
            matched(found)
            name = Path(data).name
            plot(found, folder / f"{name}_{geometry}.png", f"{geometry}, val split of {name}")
            rows += [{"dataset": name, "geometry": geometry, **r,
                      "weights": f"assets/weights/{SHIPPED[geometry]}"} for r in found]
    return rows


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

    from .config import BenchConfig

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
    matched(rows)
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
    plot(rows, out / "shadow_trade.png", f"{a.geometry}, {a.split} split of {a.data}")
    print(markdown(rows, f"`{cmd}`"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
