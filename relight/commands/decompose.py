"""``relight decompose``: a splat PLY (or a synthetic one) decomposed into relightable materials."""
from __future__ import annotations

import json
from pathlib import Path

from viewer.errors import RelightError, SceneError


def cmd_decompose(args) -> int:
    try:
        from learned.splats.decompose import DecomposeOptions, run
    except ImportError as exc:
        raise RelightError(f"relight decompose needs torch: pip install -e '.[learned]' ({exc})",
                           where="decompose") from None
    out = Path(args.out)
    if out.suffix.lower() != ".ply":
        raise SceneError("--out must end in .ply", where=out)
    if not out.resolve().parent.is_dir():
        raise SceneError("output folder does not exist", where=out.parent)
    if (args.input is None) == (not args.synthetic):
        raise SceneError("give either an input PLY or --synthetic N", where="decompose")
    for name, lo in (("views", 1), ("size", 8), ("iterations", 1), ("synthetic", 0)):
        if getattr(args, name) < lo:
            raise SceneError(f"--{name} must be at least {lo}", where=f"--{name}")
    options = DecomposeOptions(views=args.views, size=args.size, iterations=args.iterations,
                               checkpoint=args.checkpoint, seed=args.seed,
                               progress=not args.quiet and not args.json)
    report = run(args.input, out, options, synthetic=args.synthetic)
    if args.json:
        print(json.dumps(report, indent=1))
    elif not args.quiet:
        for k, v in report.items():
            print(f"{k:>17}: {v}")
    return 0
