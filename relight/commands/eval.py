"""``relight eval``: PSNR, SSIM and HDR-FLIP of every model on a dataset split."""
from __future__ import annotations

import json
from pathlib import Path

from viewer.errors import RelightError

from .argtypes import _nonnegative_float, _positive_int, _seeds
from .common import _learned


def add_parser(sub) -> None:
    """``relight eval``'s sub-command parser."""
    p = sub.add_parser("eval", help="PSNR / SSIM / HDR-FLIP of every model on held-out samples")
    p.add_argument("data", help="dataset root (FFHQ256-PBR layout with targets)")
    p.add_argument("--split", default=None,
                   help="train | val | test (default; --factors: val) | all (a held-out dataset: "
                        "every sample)")
    p.add_argument("--teacher-samples", type=int, default=128)
    p.add_argument("--limit", type=int, help="at most this many samples")
    p.add_argument("--weights", action="append", default=[], metavar="NAME=FILE",
                   help="also score this student weights file as row 'neural NAME' (repeatable)")
    p.add_argument("--teacher-weights", metavar="FILE",
                   help="the teacher's weights file (default: the shipped one)")
    p.add_argument("--shadow-weights", metavar="FILE",
                   help="a shadow UNet (relight train's RUN/shadow_final.pt): adds the row "
                        "teacher x shadow map, in torch ('N spp x shadow (torch)')")
    p.add_argument("--by", choices=("kind", "environment"),
                   help="also break the means down by the samples' scene kind or environment "
                        "(meta.json), one row per group and model; group 'all' is every sample")
    p.add_argument("--json", action="store_true")
    p.add_argument("--factors", action="store_true",
                   help="instead of scoring: what each student learned, the means of its "
                        "split-sum corrections (1 = ggx_split_sum) and its bounce gain's "
                        "percentiles over the split's surfaces (the shipped student, or each "
                        "--weights; learned/factors.py)")
    p.add_argument("--protocol", action="store_true",
                   help="the evaluation protocol on a protocol dataset (relight data OUT "
                        "--protocol): students of --seeds trained on train, the strongest "
                        "classical model given the same evidence picked on val, both scored on "
                        "test with the paired difference's bootstrap interval; resumable, cached "
                        "under DATA/_protocol; every test scoring counted in DATA/test_ledger.json")
    p.add_argument("--seeds", type=_seeds, default=(0, 1, 2), metavar="S,S,...",
                   help="--protocol: the students' training seeds (default 0,1,2)")
    p.add_argument("--degrade", type=_nonnegative_float, default=0.0, metavar="LEVEL",
                   help="--protocol: degrade every split's G-buffer inputs at LEVEL in [0, 1] "
                        "(learned/protocol/degrade.py; the thesis's estimated G-buffers; "
                        "targets stay true)")
    p.add_argument("--student-steps", type=_positive_int, metavar="N",
                   help="--protocol: training steps per student (default the shipped 24000)")
    p.add_argument("--protocol-out", metavar="DIR",
                   help="--protocol: where runs and results are cached (default DATA/_protocol)")
    p.set_defaults(func=cmd_eval)


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
        for flag, value in (("--by", args.by), ("--teacher-weights", args.teacher_weights),
                            ("--shadow-weights", args.shadow_weights)):
            if value is not None:
                raise RelightError(f"{flag} belongs to scoring, not to --factors (which reads "
                                   "the students' networks only)", where=flag)
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
