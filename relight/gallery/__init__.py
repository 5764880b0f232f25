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

The package, by job: :mod:`.cases` (what is shown, the options), :mod:`.images` (display
transform, error images, composing), :mod:`.panels` (the two panels, the truth cache),
:mod:`.report` (``gallery.md``, ``gallery.json``); here the run and the command line.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

from viewer.errors import RelightError, SceneError

from .cases import (
    CASES,
    DEFAULT_CACHE,
    DEFAULT_OUT,
    ENVIRONMENTS,
    ERROR_MAX,
    SPHERE_SCENES,
    Case,
    GalleryOptions,
)
from .images import colormap, compose, display, error_image
from .panels import asset_panel, gallery_scene, sphere_panel
from .report import _machine, write_report

__all__ = ["CASES", "ENVIRONMENTS", "ERROR_MAX", "SPHERE_SCENES", "Case", "GalleryOptions",
           "add_parser", "asset_panel", "cmd_gallery", "colormap", "compose", "display",
           "error_image", "gallery_scene", "run_gallery", "sphere_panel", "write_report"]


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
    from ..commands import _parse_size

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
