"""``relight train``: synthetic data -> teacher -> shadow estimator -> distilled student (or the
comparison of student designs), optionally on path-traced targets (``--targets reference``)."""
from __future__ import annotations

import argparse
from pathlib import Path

from viewer.errors import RelightError

from .common import _learned
from .reference import reference_tracer


# ``relight train`` options that override a field of learned.train.TrainConfig
TRAIN_OVERRIDES = ("teacher_steps", "shadow_steps", "student_steps", "batch_pixels",
                   "light_samples", "strategy", "student_target", "student_features",
                   "student_output", "student_hidden", "student_indirect",
                   "student_sun", "student_multiscatter", "student_gain_penalty",
                   "student_direct_penalty", "student_visibility",
                   "teacher_light_input", "seed")


def cmd_train(args) -> int:
    """Synthetic data (unless --data) -> teacher -> shadow estimator -> distilled student, or
    (--compare-students) the measured comparison of the candidate student designs."""
    if args.stage != "shadow_net":
        shadow_net_options(args)  # a --shadow-* option without the stage: one line naming it
    over = {k: getattr(args, k) for k in TRAIN_OVERRIDES if getattr(args, k) is not None}
    if "student_visibility" in over:  # a missing or bad file: one line naming it, before any work
        from viewer.neural.shadow_net import read_shadow_net

        read_shadow_net(over["student_visibility"])
    if "teacher_light_input" in over:  # --teacher-light-input on | off
        over["teacher_light_input"] = over["teacher_light_input"] == "on"
    if args.compare_students:
        if args.stage != "all":
            raise RelightError("--compare-students trains every stage it needs; drop --stage",
                               where="--stage")
        students = _learned("relight.bench.students")
        res = students.compare_students(args.out, data=args.data, install=args.install,
                                        quiet=args.quiet, **over)
        print(students.compare_table(res))
        return 0
    if args.stage == "shadow_net":
        return _train_shadow_net(args)
    if args.stage == "student" and over.get("student_target", "target") != "target":
        raise RelightError("the student stage alone learns from the dataset's targets: drop "
                           "--student-target teacher (a distilled student needs the teacher: "
                           "--stage all)", where="--stage")
    train = _learned("learned.train")
    data = args.data
    if getattr(args, "targets", "rasteriser") == "reference":
        data = _truth_data(args)
    elif getattr(args, "count", None) is not None:
        raise RelightError("--count sizes the dataset --targets reference generates",
                           where="--count")
    res = train.pipeline(args.out, data=data, quick=args.quick, install=args.install,
                         quiet=args.quiet, stages=args.stage, **over)
    if not args.quiet:
        for k in ("teacher", "shadow", "student", "installed_student", "installed_teacher"):
            if k in res:
                print(f"{k}: {res[k]}")
    return 0


def _train_shadow_net(args) -> int:
    """``relight train --stage shadow_net --data DATA``: the viewer's shadow estimator on the
    dataset's targets (learned/train/shadow_net.py)."""
    if not args.data:
        raise RelightError("the shadow estimator learns from a dataset's targets: give --data "
                           "(a traced one: relight data OUT --protocol)", where="--stage")
    mod = _learned("learned.train.shadow_net")
    cfg = mod.ShadowNetTrainConfig(data=args.data, out=args.out,
                                   steps=args.shadow_steps or mod.ShadowNetTrainConfig.steps,
                                   seed=args.seed or 0, **shadow_net_options(args))
    res = mod.train_shadow_net(cfg, quiet=args.quiet)
    if not args.quiet:
        print(f"shadow_net: {res['shadow_net']}")
        for k, v in res["val"].items():
            print(f"val PSNR {k} the estimator: {v['psnr']:.2f} dB")
        for d, sc in res.get("val_data", {}).items():
            print(f"{d}: val PSNR with / without the estimator: {sc['with']['psnr']:.2f} / "
                  f"{sc['without']['psnr']:.2f} dB")
    return 0


# --shadow-* option -> the field of learned.train.shadow_net.ShadowNetTrainConfig it sets (an
# omitted option keeps the field's default)
SHADOW_NET_OPTIONS = {"shadow_extra_data": "extra_data", "shadow_val_data": "val_data",
                      "shadow_degrade": "degrade_levels", "shadow_geometry": "geometry",
                      "shadow_energy": "energy_weight", "shadow_linear": "linear_weight",
                      "shadow_env_visibility": "architecture", "shadow_arch": "architecture",
                      "shadow_decals": "decals", "shadow_prior": "prior_weight",
                      "shadow_specular_occlusion": "specular_occlusion"}


def add_shadow_net_arguments(p) -> None:
    """The options of ``relight train --stage shadow_net`` (:data:`SHADOW_NET_OPTIONS`)."""
    p.add_argument("--shadow-extra-data", nargs="+", metavar="DIR",
                   help="--stage shadow_net: more datasets whose train splits join the training "
                        "images (relight data OUT --preset shadow-extra)")
    p.add_argument("--shadow-val-data", nargs="+", metavar="DIR",
                   help="--stage shadow_net: more datasets whose val split is scored after "
                        "training (relight data OUT --preset shadow-val)")
    p.add_argument("--shadow-degrade", metavar="L,L",
                   help="--stage shadow_net: DATA's train split again with its G-buffers "
                        "degraded at these levels in (0, 1] (written once under "
                        "DATA/_degraded/<level>; default 0.25,0.75 for stacks, none for "
                        "meshes; 'none': no degraded copies)")
    p.add_argument("--shadow-geometry", choices=("stack", "mesh"),
                   help="--stage shadow_net: frames drawn from each sample's image-space stack "
                        "or from its meshes")
    p.add_argument("--shadow-energy", type=float, metavar="W",
                   help="--stage shadow_net: weight of the loss term that keeps each image's "
                        "energy and its highlights' (default 0: off)")
    p.add_argument("--shadow-env-visibility", action=argparse.BooleanOptionalAction,
                   default=None,
                   help="--stage shadow_net: whether the estimator reads S(x), the SSAO pass's "
                        "visibility of the environment's light (default: stacks yes, their only "
                        "cast-shadow evidence; meshes no, their shadow maps cast the sun's, and "
                        "the estimators that read it invented shadows on real assets)")
    p.add_argument("--shadow-specular-occlusion", action=argparse.BooleanOptionalAction,
                   help="--stage shadow_net: frames with specular occlusion ([render] "
                        "specular_occlusion, the viewer's default, and this one's; the files "
                        "shipped before 2026-11-29's had none; recorded in the file's frame)")
    p.add_argument("--shadow-arch", metavar="JSON",
                   help="--stage shadow_net: architecture keys over the shipped design's, as a "
                        "JSON object (viewer/neural/shadow_net.py; e.g. '{\"upsample\": "
                        "\"bilinear\"}', '{\"demodulate\": true}', '{\"gain\": 1}')")
    p.add_argument("--shadow-linear", type=float, metavar="W",
                   help="--stage shadow_net: weight of the loss term on the linear image's "
                        "relative error (default 0: off)")
    p.add_argument("--shadow-prior", type=float, metavar="W",
                   help="--stage shadow_net: weight of the loss term mean |log V|, a prior "
                        "towards V = 1 (learned/train/shadow_terms.py; default 0: off)")
    p.add_argument("--shadow-decals", type=float, metavar="P",
                   help="--stage shadow_net: the share of training images with a random "
                        "pattern painted on frame, target and base colour alike (textures that "
                        "cast no shadow; learned/train/decals.py; default 0)")


def shadow_net_options(args) -> dict:
    """The given ``--shadow-*`` options as ShadowNetTrainConfig fields, checked: a one-line
    :class:`RelightError` naming the option."""
    out = {}
    for opt, name in SHADOW_NET_OPTIONS.items():
        value = getattr(args, opt, None)
        if value is None:
            continue
        flag = "--" + opt.replace("_", "-")
        if args.stage != "shadow_net":
            raise RelightError(f"{flag} is an option of the shadow estimator's training: give "
                               "--stage shadow_net", where=flag)
        if opt == "shadow_degrade":
            value = _levels(value, flag)
        elif opt in ("shadow_extra_data", "shadow_val_data"):
            split = "train" if opt == "shadow_extra_data" else "val"
            for d in value:
                if not (Path(d) / split).is_dir():
                    raise RelightError(f"{d}: no {split!r} split folder (a dataset of relight "
                                       "data)", where=flag)
            value = tuple(value)
        elif opt in ("shadow_energy", "shadow_linear", "shadow_prior") and \
                not 0.0 <= value < float("inf"):
            raise RelightError(f"a loss weight must be finite and >= 0, got {value}", where=flag)
        elif opt == "shadow_decals" and not 0.0 <= value <= 1.0:
            raise RelightError(f"a share must be in [0, 1], got {value}", where=flag)
        elif opt == "shadow_env_visibility":  # else the geometry's
            value = out.get(name, _shipped_architecture()) | {"env_visibility": bool(value)}
        elif opt == "shadow_arch":
            value = out.get(name, _shipped_architecture()) | _architecture_keys(value, flag)
        out[name] = value
    return out


def _shipped_architecture() -> dict:
    from learned.train.shadow_net import SHIPPED_ARCHITECTURE

    return dict(SHIPPED_ARCHITECTURE)


def _architecture_keys(text: str, flag: str) -> dict:
    """``--shadow-arch``'s JSON object, checked over the shipped design by the weights file's
    own rules (:func:`viewer.neural.shadow_net.check_architecture`): one line naming the flag."""
    import json

    from viewer.neural.shadow_net import check_architecture

    try:
        keys = json.loads(text)
    except ValueError as exc:
        raise RelightError(f"not JSON ({exc})", where=flag) from None
    if not isinstance(keys, dict):
        raise RelightError(f"not a JSON object: {text!r}", where=flag)
    if "env_visibility" in keys:  # one way to say it, and the geometry's default otherwise
        raise RelightError("env_visibility is --shadow-env-visibility's", where=flag)
    try:
        check_architecture(_shipped_architecture() | keys)
    except (TypeError, ValueError) as exc:
        raise RelightError(str(exc), where=flag) from None
    return keys


def _levels(text: str, flag: str) -> tuple[float, ...]:
    """``0.25,0.5`` -> (0.25, 0.5): distinct levels in (0, 1]; ``none`` -> () (no degraded
    copies)."""
    if text.strip().lower() == "none":
        return ()
    try:
        levels = tuple(float(t) for t in text.split(","))
    except ValueError:
        raise RelightError(f"not comma-separated numbers: {text!r}", where=flag) from None
    if not all(0.0 < lv <= 1.0 for lv in levels):
        raise RelightError(f"levels must be in (0, 1], got {text!r}", where=flag)
    if len(set(levels)) != len(levels):
        raise RelightError(f"levels repeat: {text!r}", where=flag)
    return levels


def _truth_data(args) -> str:
    """``relight train --targets reference``: the ``truth-train`` preset (:func:`_truth_config`:
    path-traced targets, the truth scene kinds (contact, clusters, concave meshes, glTF models)
    and the real HDRIs sky and park beside the procedural environments; esplanade and the nested
    kinds stay held out), generated under OUT/data-truth by every torchrun rank (sample i by rank
    i % WORLD_SIZE), resumable; returns its folder."""
    if args.data is not None:
        raise RelightError("--targets makes the generated dataset; drop --data (a given dataset "
                           "brings its own targets)", where="--targets")
    if args.compare_students:
        raise RelightError("--compare-students generates its own data; drop --targets",
                           where="--targets")
    data = str(Path(args.out) / "data-truth")
    _learned("learned.data.generator").generate(data, _truth_config(args), progress=not args.quiet,
                                                shard=True, tracer=reference_tracer())
    return data


def _truth_config(args):
    """The dataset of ``relight train --targets reference``: the ``truth-train`` preset
    (``relight data --preset truth-train``) with ``--count`` samples (default the quick dataset's
    40) and ``--reference-spp``."""
    count = getattr(args, "count", None)
    if count is None:
        count = _learned("learned.train.config").QUICK_DATA["count"]
    return _learned("learned.data.presets").preset_config(
        "truth-train", count=int(count), reference_spp=args.reference_spp)
