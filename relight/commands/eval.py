"""``relight eval``: PSNR, SSIM and HDR-FLIP of every model on a dataset split."""
from __future__ import annotations

import json
from pathlib import Path

from viewer.errors import RelightError

from .common import _learned


def cmd_eval(args) -> int:
    """PSNR, SSIM and HDR-FLIP of every model against the Monte-Carlo targets of a split, or
    (``--protocol``) the evaluation protocol (:mod:`learned.protocol.run`)."""
    if getattr(args, "protocol", False):
        if getattr(args, "factors", False):
            raise RelightError("--factors and --protocol are two different runs", where="--factors")
        return _protocol(args)
    for flag, value in (("--degrade", getattr(args, "degrade", 0.0)),
                        ("--student-steps", getattr(args, "student_steps", None))):
        if value:
            raise RelightError(f"{flag} belongs to --protocol", where=flag)
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
    if getattr(args, "factors", False):
        return _factors(args, students)
    rows = ev.evaluate(args.data, split=args.split or "test", teacher_samples=args.teacher_samples,
                       limit=args.limit, students=students, by=args.by,
                       teacher_weights=args.teacher_weights, shadow_weights=args.shadow_weights)
    if args.json:
        print(json.dumps(rows, indent=1))
    else:
        print(ev.format_table(rows))
    return 0


def _protocol(args) -> int:
    """``relight eval DATA --protocol``: students of ``--seeds`` against the strongest classical
    model given the same evidence, on the protocol dataset's test split (printed with how many
    times it has been scored)."""
    run = _learned("learned.protocol.run")
    if args.degrade > 1.0:
        raise RelightError(f"--degrade {args.degrade:g} is not in [0, 1]", where="--degrade")
    if len(args.weights) > 1:
        raise RelightError("--protocol scores one given weights file (--weights NAME=FILE)",
                           where="--weights")
    shipped = None
    for item in args.weights:
        _, sep, path = item.partition("=")
        if not sep or not Path(path).is_file():
            raise RelightError("weights file not found (expected NAME=FILE)", where=item)
        shipped = path
    kw = {"student_steps": args.student_steps} if args.student_steps else {}
    cfg = run.ProtocolConfig(data=args.data, out=args.protocol_out, seeds=tuple(args.seeds),
                             level=float(args.degrade), shipped=shipped, **kw)
    report = run.run_protocol(cfg)
    print(json.dumps(report, indent=1) if args.json else run.format_report(report))
    return 0


def _factors(args, students: dict) -> int:
    """``relight eval DATA --factors``: the statistics of each student's corrections
    (:mod:`learned.factors`); the shipped student without ``--weights``."""
    from viewer.neural import default_weights

    factors = _learned("learned.factors")
    students = students or {"shipped": str(default_weights("student"))}
    rows = factors.student_factors(args.data, args.split or "val", students, args.limit)
    print(json.dumps(rows, indent=1) if args.json else factors.format_factors(rows))
    return 0
