"""``relight eval``: PSNR, SSIM and HDR-FLIP of every model on a dataset split."""
from __future__ import annotations

import json
from pathlib import Path

from viewer.errors import RelightError

from .common import _learned


def cmd_eval(args) -> int:
    """PSNR, SSIM and HDR-FLIP of every model against the Monte-Carlo targets of a split."""
    ev = _learned("learned.evaluate")
    students = {}
    for item in args.weights:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise RelightError(f"--weights {item!r}: expected NAME=FILE", where="--weights")
        if not Path(path).is_file():
            raise RelightError("weights file not found", where=path)
        students[name] = path
    for path in (args.teacher_weights, args.shadow_weights):
        if path is not None and not Path(path).is_file():
            raise RelightError("weights file not found", where=path)
    rows = ev.evaluate(args.data, split=args.split, teacher_samples=args.teacher_samples,
                       limit=args.limit, students=students, by=args.by,
                       teacher_weights=args.teacher_weights, shadow_weights=args.shadow_weights)
    if args.json:
        print(json.dumps(rows, indent=1))
    else:
        print(ev.format_table(rows))
    return 0
