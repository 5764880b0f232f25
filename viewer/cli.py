"""``relight``: the command line of the relighting workbench.

    relight render [SCENE.toml] --out FILE [--model M] [--samples N] [--size WxH] [--aov a,b]
    relight parity [--model M] [--json]
    relight info [--json]

Errors a user can cause print one line, ``relight: error: <file>: <problem>``, and exit with 2,
writing nothing.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from .errors import RelightError, SceneError

DEMO_SCENE = "demo.toml"


def _demo_path() -> Path:
    from assets import ASSET_ROOT

    return ASSET_ROOT / "scenes" / DEMO_SCENE


def _parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise SceneError(f"--size must look like 512x512, got {text!r}", where="--size") from None
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise SceneError(f"--size {w}x{h} is outside 1..16384", where="--size")
    return w, h


def _context_options(args):
    from .gl import ContextOptions

    return ContextOptions(software=getattr(args, "software", False))


def cmd_render(args) -> int:
    from .imageio import write_exr, write_png
    from .models import model_info
    from .renderer import AOV_NAMES, Renderer
    from .scene import TONEMAPS, load_scene

    out = Path(args.out)
    if out.suffix.lower() not in (".exr", ".png"):
        raise SceneError("--out must end in .exr (linear radiance) or .png (tone-mapped sRGB)",
                         where=out)
    if not out.resolve().parent.is_dir():
        raise SceneError("output folder does not exist", where=out.parent)
    scene = load_scene(args.scene or _demo_path())
    changes = {}
    if args.model is not None:
        model_info(args.model)
        changes["model"] = args.model
    if args.samples is not None:
        if args.samples < 1:
            raise SceneError(f"--samples must be at least 1, got {args.samples}", where="--samples")
        changes["samples"] = args.samples
    if args.exposure is not None:
        changes["exposure"] = args.exposure
    if args.tonemap is not None:
        if args.tonemap not in TONEMAPS:
            raise SceneError(f"--tonemap must be one of {', '.join(TONEMAPS)}", where="--tonemap")
        changes["tonemap"] = args.tonemap
    if changes:
        scene = scene.with_render(**changes)
    aovs = [a.strip() for a in args.aov.split(",") if a.strip()] if args.aov else []
    unknown = [a for a in aovs if a not in AOV_NAMES]
    if unknown:
        raise SceneError(f"unknown AOV {', '.join(map(repr, unknown))} "
                         f"(known: {', '.join(AOV_NAMES)})", where="--aov")
    size = _parse_size(args.size) if args.size else None

    renderer = Renderer(options=_context_options(args))
    try:
        frame = renderer.render(scene, aovs=tuple(aovs), size=size)
    finally:
        renderer.release()
    # everything is in memory before the first file is written: an error writes nothing
    if out.suffix.lower() == ".exr":
        rgba = frame.radiance if scene.render.background == "transparent" else frame.radiance[..., :3]
        write_exr(out, rgba, ["R", "G", "B", "A"][: rgba.shape[2]])
    else:
        keep = 4 if scene.render.background == "transparent" else 3
        write_png(out, frame.display[..., :keep])
    written = [out]
    for name in aovs:
        arr = frame.aovs[name]
        names = {1: ["Y"], 3: ["R", "G", "B"]}.get(arr.shape[2])
        path = out.with_name(f"{out.stem}.{name}.exr")
        write_exr(path, arr, names)
        written.append(path)
    if not args.quiet:
        cam = frame.camera
        print(f"rendered {Path(scene.source).name if scene.source else 'scene'} "
              f"({scene.render.model}, {cam.width}x{cam.height}) -> "
              + ", ".join(str(p) for p in written))
    return 0


def cmd_parity(args) -> int:
    try:
        from learned.parity import run_parity
    except ImportError as exc:
        raise RelightError(f"relight parity needs torch: pip install -e '.[learned]' ({exc})",
                           where="parity") from None
    from .gl import Programs, create_context
    from .models import model_info

    if args.model is not None:
        model_info(args.model)
    ctx = create_context(_context_options(args))
    try:
        results = run_parity(Programs(ctx), model=args.model, seed=args.seed)
    finally:
        ctx.release()
    if args.json:
        print(json.dumps([r.as_json() for r in results], indent=1))
    else:
        width = max((len(r.name) for r in results), default=10)
        print(f"{'name':<{width}}  {'kind':<8} {'max_abs':>10} {'max_rel':>10}  tolerance")
        for r in results:
            flag = "ok  " if r.passed else "FAIL"
            print(f"{r.name:<{width}}  {r.kind:<8} {r.max_abs:10.3g} {r.max_rel:10.3g}  "
                  f"{r.tolerance}  {flag}")
        failed = sum(not r.passed for r in results)
        print(f"{len(results) - failed} passed, {failed} failed")
    return 0 if all(r.passed for r in results) else 1


def cmd_info(args) -> int:
    from .gl import create_context, gl_info

    ctx = create_context(_context_options(args))
    try:
        info = gl_info(ctx)
    finally:
        ctx.release()
    if args.json:
        print(json.dumps(info, indent=1))
        return 0
    exts = info.pop("extensions")
    for k, v in info.items():
        print(f"{k:>26}: {v}")
    print(f"{'extensions':>26}: {len(exts)} ({', '.join(exts[:6])}, ...)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="relight", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("render", help="render a scene headlessly to EXR (linear) or PNG")
    p.add_argument("scene", nargs="?", help="scene TOML (default: the built-in demo)")
    p.add_argument("--out", required=True, help="output .exr (linear radiance) or .png")
    p.add_argument("--model", help="shading model (overrides [render] model)")
    p.add_argument("--samples", type=int, help="samples per pixel for sampling models")
    p.add_argument("--size", help="WxH (overrides [camera] size)")
    p.add_argument("--aov", help="comma-separated G-buffer channels written to <out>.<name>.exr")
    p.add_argument("--exposure", type=float, help="EV stops (PNG only)")
    p.add_argument("--tonemap", help="none | aces | reinhard (PNG only)")
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("parity", help="compare every GLSL function and pass with its torch twin")
    p.add_argument("--model", help="only this shading model's passes")
    p.add_argument("--json", action="store_true")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    p.set_defaults(func=cmd_parity)

    p = sub.add_parser("info", help="GL renderer, version, extensions, float target precision")
    p.add_argument("--json", action="store_true")
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    p.set_defaults(func=cmd_info)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except RelightError as exc:
        print(f"relight: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
