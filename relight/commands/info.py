"""``relight info``: the OpenGL context's renderer, version, limits and extensions; with
``--weights``, where neural-shader and shadow-estimator weights files come from
(:func:`weights_provenance`)."""
from __future__ import annotations

import json
from pathlib import Path

from viewer.errors import RelightError

from .common import _context_options

# the provenance fields shown, from the file's metadata ("training") or the JSON beside it
PROVENANCE = ("command", "seed", "dataset", "dataset_hash", "val_psnr", "test_psnr",
              "test_scored", "test", "note")


def weights_provenance(path) -> dict:
    """What made a weights file: its kind and checkpoint hash, and the command, seed, dataset
    hash and validation / test scores recorded in its metadata (``training``) or in the JSON
    beside it (``<file>.json``, which wins: test scores are added after a file is written)."""
    from viewer.neural import load_network
    from viewer.neural.shadow_net import (
        FORMAT,
        file_format,
        read_shadow_net,
        receptive_field,
    )

    path = Path(path)
    if file_format(path) == FORMAT:  # the neural shadow estimator ([render] shadow_net)
        net = read_shadow_net(path)
        out = {"file": str(path), "kind": "shadow_net", "checkpoint": net.checkpoint,
               "architecture": net.architecture,
               "receptive_field_px": receptive_field(net.architecture)}
    else:
        net = load_network(path)
        out = {"file": str(path), "kind": net.kind, "checkpoint": net.checkpoint}
    training = dict(net.training or {})
    scores = training.get("scores", {})
    for key in PROVENANCE:
        if key in training:
            out[key] = training[key]
        elif key in scores:
            out[key] = scores[key]
    if "seed" not in out and isinstance(training.get("config"), dict):
        out["seed"] = training["config"].get("seed")
    beside = path.with_suffix(".json")
    if beside.is_file():
        try:
            extra = json.loads(beside.read_text())
        except ValueError as exc:
            raise RelightError(f"not valid JSON ({exc})", where=beside) from None
        out |= {k: extra[k] for k in PROVENANCE if k in extra}
    return out


def _print_weights(args) -> int:
    from viewer.neural import default_weights

    files = args.weights or [str(default_weights(k))
                             for k in ("student", "student_visibility", "teacher")]
    rows = []
    for f in files:
        if not Path(f).is_file():
            raise RelightError("weights file not found", where=f)
        rows.append(weights_provenance(f))
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    for r in rows:
        print(r["file"])
        for k, v in r.items():
            if k != "file":
                print(f"{k:>14}: {json.dumps(v) if isinstance(v, (dict, list)) else v}")
    return 0


def cmd_info(args) -> int:
    from viewer.gl import create_context, gl_info

    if getattr(args, "weights", None) is not None:
        return _print_weights(args)

    ctx = create_context(_context_options(args))
    try:
        info = gl_info(ctx)
    finally:
        ctx.release()
    if args.json:
        print(json.dumps(info, indent=1))
        return 0
    exts = info.pop("extensions")
    if info.get("glsl") is None:  # glGetString through EGL failed: say so, not "None"
        info["glsl"] = "unknown (GL_SHADING_LANGUAGE_VERSION could not be read through EGL)"
    for k, v in info.items():
        print(f"{k:>26}: {v}")
    print(f"{'extensions':>26}: {len(exts)} ({', '.join(exts[:6])}, ...)")
    return 0
