"""``relight gallery``: every shading model beside the path-traced truth, as pictures.

Two panels, both written as small PNGs with a Markdown table of the errors (``gallery.md``, which
the documentation's gallery page includes) and the raw numbers (``gallery.json``):

* **a real asset under real light**: the glTF scene ``assets/scenes/gallery.toml`` (the plasma
  gun of ``assets/models/cge_plasma_gun`` on a floor) under each HDRI of
  :data:`ENVIRONMENTS`, rendered with every case of :data:`CASES` and path-traced with
  :func:`relight.reference.render_reference` (Mitsuba 3, our BSDF; cached under ``--cache``, so
  a second run only rasterises). ``hero.png`` is the README's picture (a few models, the truth);
  ``<environment>.png`` has every case with its error image below it.
* **the fidelity spheres**: the scenes of ``assets/scenes/reference`` against their stored
  4,096-spp references (``assets/references``), ``spheres.png``.

Every image goes through the same display transform (exposure 0, Hill's ACES fit, sRGB), the
truth included. An error image shows the per-pixel relative error ``|image - truth|_1 /
|truth|_1`` (the quantity whose median :func:`relight.reference.compare.score` reports) less
what twice the truth's standard error explains, from 0 (black) to :data:`ERROR_MAX` (yellow);
pixels not covered by geometry are grey. The tables hold the plain scores.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from viewer.errors import RelightError, SceneError

ERROR_MAX = 0.5  # relative error at the top of the error colour map
DEFAULT_OUT = "assets/docs/gallery"
DEFAULT_CACHE = "out/gallery-cache"


@dataclass(frozen=True)
class Case:
    """One column of the gallery: a label and the ``[render]`` settings it changes."""

    label: str
    render: dict = field(default_factory=dict)
    hero: bool = False  # shown in the README picture


CASES: tuple[Case, ...] = (
    Case("unlit", {"model": "unlit"}),
    Case("blinn_phong", {"model": "blinn_phong"}, hero=True),
    Case("ggx_split_sum", {"model": "ggx_split_sum"}, hero=True),
    Case("ggx_split_sum + SSAO + indirect",
         {"model": "ggx_split_sum", "ssao": True, "indirect": True}),
    Case("ggx_mc 256 spp", {"model": "ggx_mc", "samples": 256}, hero=True),
    Case("neural", {"model": "neural"}, hero=True),
    Case("neural_teacher 128 spp", {"model": "neural_teacher", "samples": 128}),
)

# (name, file under assets/environments, rotation_deg): each HDRI turned so that its sun lights
# the side of the asset the camera sees
ENVIRONMENTS: tuple[tuple[str, str, float], ...] = (
    ("park", "park.exr", 336.0),
    ("sky", "sky.exr", 334.0),
    ("esplanade", "esplanade.exr", 0.0),
)

# fidelity scenes shown in spheres.png (all of assets/scenes/reference are scored in the table)
SPHERE_SCENES = ("park_diffuse", "park_conductor_r005", "park_conductor_r03",
                 "sky_conductor_r08", "esplanade_conductor_r03", "park_sphere_on_plane")


@dataclass(frozen=True)
class GalleryOptions:
    out: Path = Path(DEFAULT_OUT)
    cache: Path = Path(DEFAULT_CACHE)
    size: tuple[int, int] | None = None  # None: the gallery scene's own
    spp: int = 512                       # path-traced samples per pixel of the asset's truth
    quick: bool = False                  # 64 spp, one environment (a smoke run)
    spheres: bool = True                 # also the fidelity-sphere panel
    progress: bool = True


# ---- display and error images -------------------------------------------------------------------

_ACES_IN = np.array([[0.59719, 0.35458, 0.04823],
                     [0.07600, 0.90834, 0.01566],
                     [0.02840, 0.13383, 0.83777]])
_ACES_OUT = np.array([[1.60475, -0.53108, -0.07367],
                      [-0.10208, 1.10813, -0.00605],
                      [-0.00327, -0.07276, 1.07602]])


def display(radiance: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """``[H, W, 3]`` uint8 sRGB of linear ``radiance``: the renderer's display transform (exposure,
    Hill's ACES fit, sRGB encoding; ``shaders/lib/tonemap.glsl``) in numpy."""
    v = np.clip(np.asarray(radiance[..., :3], np.float64) * 2.0 ** exposure, 0.0, 1e4) @ _ACES_IN.T
    a = v * (v + 0.0245786) - 0.000090537
    b = v * (0.983729 * v + 0.4329510) + 0.238081
    x = np.clip((a / b) @ _ACES_OUT.T, 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return (s * 255.0 + 0.5).astype(np.uint8)


# a perceptually ordered ramp (black -> purple -> orange -> yellow), close to matplotlib's inferno
_RAMP = np.array([[0, 0, 4], [40, 11, 84], [101, 21, 110], [159, 42, 99], [212, 72, 66],
                  [245, 125, 21], [250, 193, 39], [252, 255, 164]], np.float64)


def colormap(t: np.ndarray) -> np.ndarray:
    """``[..., 3]`` uint8 colours of ``t`` in [0, 1] (clipped) along :data:`_RAMP`."""
    x = np.clip(np.nan_to_num(t), 0.0, 1.0) * (len(_RAMP) - 1)
    i = np.minimum(np.floor(x).astype(np.int64), len(_RAMP) - 2)
    f = (x - i)[..., None]
    return (_RAMP[i] * (1.0 - f) + _RAMP[i + 1] * f + 0.5).astype(np.uint8)


def error_image(image: np.ndarray, truth, mask: np.ndarray) -> np.ndarray:
    """``[H, W, 3]`` uint8: the per-pixel relative error beyond the truth's own noise,
    ``max(|image - truth|_1 - 2 |stderr|_1, 0) / |truth|_1`` (``truth`` a
    :class:`~relight.reference.Reference`), through :func:`colormap` from 0 to
    :data:`ERROR_MAX`; grey where ``mask`` is false."""
    a = np.asarray(image[..., :3], np.float64)
    b = np.asarray(truth.radiance[..., :3], np.float64)
    noise = 2.0 * np.asarray(truth.stderr[..., :3], np.float64).sum(-1)
    rel = np.maximum(np.abs(a - b).sum(-1) - noise, 0.0) / np.maximum(b.sum(-1), 1e-6)
    out = colormap(rel / ERROR_MAX)
    out[~mask] = 64
    return out


# ---- composing ----------------------------------------------------------------------------------

def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)  # Pillow >= 10.1: a scalable font
    except TypeError:  # pragma: no cover - older Pillow: the fixed bitmap font
        return ImageFont.load_default()


def compose(grid: list[list[np.ndarray | None]], col_labels: list[str], row_labels: list[str],
            scale: int = 1, note: str | None = None, font_size: int = 13):
    """A PIL image of ``grid`` (rows of equally sized uint8 tiles, ``None`` left blank) with a
    label above each column and left of each row (rows with an empty label get none)."""
    from PIL import Image, ImageDraw

    tiles = [t for row in grid for t in row if t is not None]
    th, tw = tiles[0].shape[0] * scale, tiles[0].shape[1] * scale
    font = _font(font_size)
    left = 8 + max((int(ImageDraw.Draw(Image.new("RGB", (1, 1))).textlength(s, font=font))
                    for s in row_labels), default=0)
    lines = max((label.count("\n") + 1 for label in col_labels), default=1)
    top, gap = lines * (font_size + 2) + 8, 2
    bottom = font_size + 10 if note else 0
    ncols = max(len(r) for r in grid)
    width = left + ncols * (tw + gap)
    height = top + len(grid) * (th + gap) + bottom
    img = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    for j, label in enumerate(col_labels):
        x = left + j * (tw + gap) + tw / 2
        draw.multiline_text((x, top / 2), label, fill=(0, 0, 0), font=font, anchor="mm",
                            align="center")
    for i, row in enumerate(grid):
        y = top + i * (th + gap)
        if row_labels[i]:
            draw.text((4, y + th / 2), row_labels[i], fill=(0, 0, 0), font=font, anchor="lm")
        for j, tile in enumerate(row):
            if tile is None:
                continue
            t = Image.fromarray(tile)
            if scale != 1:
                t = t.resize((tw, th), Image.NEAREST)
            img.paste(t, (left + j * (tw + gap), y))
    if note:
        draw.text((4, height - bottom / 2), note, fill=(60, 60, 60), font=font, anchor="lm")
    return img


def _save_png(img, path: Path) -> Path:
    """Saved as an adaptive 256-colour palette PNG: a fraction of the bytes of RGB, and the
    pictures are for looking at (the numbers are in gallery.json)."""
    from PIL import Image

    quantize, dither = getattr(Image, "Quantize", Image), getattr(Image, "Dither", Image)
    img.quantize(colors=256, method=quantize.MEDIANCUT,
                 dither=dither.FLOYDSTEINBERG).save(path, optimize=True)
    return path


# ---- the asset under real light -----------------------------------------------------------------

def gallery_scene(environment: tuple[str, str, float], size: tuple[int, int] | None = None):
    """The gallery scene (``assets/scenes/gallery.toml``) under one entry of
    :data:`ENVIRONMENTS`."""
    from assets import ASSET_ROOT
    from viewer import load_scene

    scene = load_scene(ASSET_ROOT / "scenes" / "gallery.toml")
    _, file, rotation = environment
    scene = scene.with_environment(path=str(ASSET_ROOT / "environments" / file),
                                   rotation_deg=rotation)
    return scene.with_camera(size=size) if size is not None else scene


def _truth(scene, name: str, options: GalleryOptions, spp: int):
    """The path-traced reference of ``scene``, from the cache when it has this configuration."""
    from .reference import ReferenceOptions, read_reference, render_reference, write_reference
    from .reference.render import config_key

    ref_options = ReferenceOptions(spp=spp)
    out = options.cache / f"{name}.exr"
    meta = out.with_suffix(".json")
    if meta.is_file():
        try:
            done = json.loads(meta.read_text())
        except ValueError:
            done = {}
        if done.get("key") == config_key(scene, ref_options) and done.get("spp", 0) >= spp:
            return read_reference(out)
    options.cache.mkdir(parents=True, exist_ok=True)
    ref = render_reference(scene, ref_options, checkpoint=out.with_name(out.name + ".partial.npz"),
                           progress=options.progress)
    write_reference(ref, out)
    return ref


def _row(label: str, case: Case, s, extra: dict | None = None) -> dict:
    row = {"scene": label, "case": case.label, "bias_%": round(100 * s.bias, 2),
           "median_rel_%": round(100 * s.median_rel, 2), "psnr_db": round(s.psnr, 2),
           "pixels": s.pixels}
    row.update(extra or {})
    return row


def asset_panel(renderer, options: GalleryOptions, log) -> tuple[list[dict], list[Path], dict]:
    """Render the gallery scene under every environment with every case and path-trace it;
    writes ``hero.png`` and ``<environment>.png``; returns the score rows, the files and the
    truth's metadata per environment."""
    from .reference.compare import coverage_mask, score

    envs = ENVIRONMENTS[:1] if options.quick else ENVIRONMENTS
    spp = 64 if options.quick else options.spp
    rows, files, truths = [], [], {}
    hero_grid, hero_rows = [], []
    hero_cases = [c for c in CASES if c.hero]
    for env in envs:
        name = env[0]
        scene = gallery_scene(env, options.size)
        log(f"{name}: path tracing ({spp} spp)")
        truth = _truth(scene, name, options, spp)
        truths[name] = {k: truth.meta.get(k) for k in ("spp", "max_depth", "variant", "mitsuba",
                                                        "seconds", "size")}
        images, errors = {}, {}
        for case in CASES:
            log(f"{name}: {case.label}")
            radiance = renderer.render(scene.with_render(**case.render)).radiance
            mask = coverage_mask(radiance, truth)
            rows.append(_row(name, case, score(radiance, truth, mask)))
            images[case.label] = display(radiance)
            errors[case.label] = error_image(radiance, truth, mask)
        truth_img = display(truth.radiance)
        labels = [c.label for c in CASES] + ["path-traced truth"]
        grid = [[images[c.label] for c in CASES] + [truth_img],
                [errors[c.label] for c in CASES] + [None]]
        img = compose(grid, labels, ["image", "error"],
                      note=f"{name}.exr; error: relative, beyond 2 standard errors of the "
                           f"truth, black 0 to yellow {ERROR_MAX:.0%} (grey: sky); truth: "
                           f"Mitsuba 3, {truth.meta['spp']} spp")
        files.append(_save_png(img, options.out / f"{name}.png"))
        hero_grid.append([images[c.label] for c in hero_cases] + [truth_img])
        hero_rows.append(name)
    hero = compose(hero_grid, [c.label for c in hero_cases] + ["path-traced truth"], hero_rows)
    files.insert(0, _save_png(hero, options.out / "hero.png"))
    return rows, files, truths


# ---- the fidelity spheres -----------------------------------------------------------------------

def sphere_panel(renderer, options: GalleryOptions, log) -> tuple[list[dict], list[Path]]:
    """Every case on every scene of ``assets/scenes/reference`` that has a stored reference,
    scored against it; ``spheres.png`` shows :data:`SPHERE_SCENES` (image above error)."""
    from assets import ASSET_ROOT
    from viewer import load_scene

    from .reference import read_reference
    from .reference.compare import coverage_mask, score

    rows, grid, labels = [], [], []
    for path in sorted((ASSET_ROOT / "scenes" / "reference").glob("*.toml")):
        ref_path = ASSET_ROOT / "references" / f"{path.stem}.exr"
        if not ref_path.is_file():
            continue
        truth = read_reference(ref_path)
        scene = load_scene(path)
        log(f"spheres: {path.stem}")
        images, errors = [], []
        for case in CASES:
            radiance = renderer.render(scene.with_render(**case.render)).radiance
            mask = coverage_mask(radiance, truth)
            rows.append(_row(path.stem, case, score(radiance, truth, mask),
                             {"truth_spp": truth.meta.get("spp")}))
            images.append(display(radiance))
            errors.append(error_image(radiance, truth, mask))
        if path.stem in SPHERE_SCENES:
            grid += [images + [display(truth.radiance)], errors + [None]]
            labels += [path.stem, ""]
    if not grid:
        return rows, []
    img = compose(grid, [c.label.replace(" + ", "\n+ ") for c in CASES] + ["truth"], labels,
                  scale=2, font_size=11,
                  note=f"under each row of images its error: black 0 to yellow {ERROR_MAX:.0%}")
    return rows, [_save_png(img, options.out / "spheres.png")]


# ---- report -------------------------------------------------------------------------------------

def _machine(renderer) -> dict:
    from viewer.gl import gl_info

    info = gl_info(renderer.ctx)
    return {"gl_renderer": info.get("renderer"), "gl_version": info.get("version"),
            "cpus": os.cpu_count(), "platform": platform.platform(),
            "python": sys.version.split()[0], "date": time.strftime("%Y-%m-%d %H:%M:%S")}


def _table(rows: list[dict], scenes: list[str]) -> list[str]:
    lines = ["| case | " + " | ".join(scenes) + " |", "|---|" + "---|" * len(scenes)]
    by = {(r["scene"], r["case"]): r for r in rows}
    for case in CASES:
        cells = []
        for s in scenes:
            r = by.get((s, case.label))
            cells.append("" if r is None else
                         f"{r['psnr_db']:.1f} / {r['median_rel_%']:.1f} / {r['bias_%']:+.1f}")
        lines.append(f"| `{case.label}` | " + " | ".join(cells) + " |")
    return lines


def write_report(report: dict, out: Path) -> list[Path]:
    """``gallery.json`` (everything) and ``gallery.md`` (the tables, the command, the machine)."""
    m = report["machine"]
    md = [f"Made by `{report['command']}` in {report['seconds']:.0f} s on {m['gl_renderer']} "
          f"({m['cpus']} CPUs, {m['platform']}), {m['date']}.", ""]
    asset = [r for r in report["rows"] if r["panel"] == "asset"]
    if asset:
        envs = list(dict.fromkeys(r["scene"] for r in asset))
        spps = sorted({t["spp"] for t in report["truth"].values()})
        md += ["**The glTF asset** (`assets/scenes/gallery.toml`) against its path-traced truth "
               f"(Mitsuba 3, our BSDF, {', '.join(map(str, spps))} spp, path depth 6). Each cell: "
               "PSNR dB / median per-pixel relative error % / energy bias % over the pixels "
               "geometry covers (`relight.reference.compare.score`).", ""]
        md += _table(asset, envs) + [""]
    spheres = [r for r in report["rows"] if r["panel"] == "spheres"]
    if spheres:
        scenes = list(dict.fromkeys(r["scene"] for r in spheres))
        md += ["**The fidelity scenes** (`assets/scenes/reference`, 64 x 64) against their stored "
               "4,096-spp references (`assets/references`); the same three numbers. These scenes "
               "trace single scattering (`multiscatter = false`).", ""]
        half = (len(scenes) + 1) // 2
        for part in (scenes[:half], scenes[half:]):
            if part:
                md += _table(spheres, part) + [""]
    (out / "gallery.md").write_text("\n".join(md))
    (out / "gallery.json").write_text(json.dumps(report, indent=1) + "\n")
    return [out / "gallery.md", out / "gallery.json"]


def run_gallery(options: GalleryOptions = GalleryOptions(), command: str = "relight gallery"
                ) -> dict:
    """Make every picture and table of the gallery under ``options.out``; returns the report
    (what ``gallery.json`` holds) with ``files`` added."""
    from viewer import Renderer

    options.out.mkdir(parents=True, exist_ok=True)
    log = (lambda msg: print(f"gallery: {msg}", file=sys.stderr, flush=True)) if options.progress \
        else (lambda msg: None)
    t0 = time.perf_counter()
    renderer = Renderer()
    try:
        with warnings.catch_warnings():
            # the asset's skin and animations are ignored (it is drawn in its bind pose)
            warnings.filterwarnings("ignore", message=".*ignored \\(not supported\\).*")
            rows, files, truths = asset_panel(renderer, options, log)
            rows = [dict(r, panel="asset") for r in rows]
            if options.spheres:
                srows, sfiles = sphere_panel(renderer, options, log)
                rows += [dict(r, panel="spheres") for r in srows]
                files += sfiles
        machine = _machine(renderer)
    finally:
        renderer.release()
    report = {"command": command, "seconds": round(time.perf_counter() - t0, 1),
              "machine": machine, "truth": truths, "error_max": ERROR_MAX,
              "cases": [{"label": c.label, "render": c.render} for c in CASES], "rows": rows}
    files += write_report(report, options.out)
    report["files"] = [str(f) for f in files]
    return report


# ---- command line -------------------------------------------------------------------------------

def add_parser(sub) -> argparse.ArgumentParser:
    """Register ``relight gallery`` on the sub-command set ``sub`` of :mod:`relight.cli`."""
    p = sub.add_parser("gallery", help="every model beside the path-traced truth: PNGs + tables",
                       description="Render the gallery scene (a glTF asset on a floor, "
                       "assets/scenes/gallery.toml) under each HDRI with every shading model, "
                       "path-trace it (Mitsuba 3: the 'reference' extra, libLLVM >= 19 for "
                       "speed), and write hero.png (the README picture), one PNG per "
                       "environment with error images, spheres.png (the fidelity scenes "
                       "against their stored references), gallery.md and gallery.json. The "
                       "path-traced images are cached in --cache.")
    p.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})")
    p.add_argument("--cache", default=DEFAULT_CACHE,
                   help=f"path-traced references, reused by the next run (default {DEFAULT_CACHE})")
    p.add_argument("--spp", type=int, default=512,
                   help="path-traced samples per pixel of the asset's truth (default 512)")
    p.add_argument("--size", help="WxH (default: the gallery scene's, 240x160)")
    p.add_argument("--quick", action="store_true",
                   help="one environment, 64 spp: a smoke run (minutes less)")
    p.add_argument("--no-spheres", action="store_true", help="leave out the fidelity spheres")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_gallery)
    return p


def cmd_gallery(args) -> int:
    from .commands import _parse_size

    if args.spp < 1:
        raise SceneError("--spp must be at least 1", where="--spp")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise SceneError("--out must be a folder", where=out)
    options = GalleryOptions(out=out, cache=Path(args.cache),
                             size=_parse_size(args.size) if args.size else None, spp=args.spp,
                             quick=args.quick, spheres=not args.no_spheres,
                             progress=not args.quiet)
    argv = ["relight gallery"] + [a for a in sys.argv[2:]] if sys.argv[1:2] == ["gallery"] \
        else ["relight gallery"]
    try:
        report = run_gallery(options, command=" ".join(argv))
    except ImportError as exc:
        raise RelightError(f"relight gallery needs Mitsuba 3 for the truth: pip install -e "
                           f"'.[reference]' ({exc})", where="gallery") from None
    if not args.quiet:
        print(f"gallery: {len(report['files'])} files in {out} ({report['seconds']:.0f} s)")
    return 0
