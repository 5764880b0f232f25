"""``relight reference``: path-traced references (:mod:`relight.reference`), and the path tracer
the dataset generator takes its targets from (:func:`reference_tracer`)."""
from __future__ import annotations

from pathlib import Path

from viewer.errors import RelightError, SceneError

from .common import _parse_size


def cmd_reference(args) -> int:
    """Path-traced references (module :mod:`relight.reference`): one scene to ``--out``, or several
    to ``--out-dir``, this process taking every ``WORLD_SIZE``-th scene from ``RANK`` (torchrun).
    A scene whose finished reference has the same configuration and at least ``--spp`` samples
    is skipped; an interrupted one resumes from ``<out>.partial.npz``."""
    import os

    from viewer.scene.description import load_scene

    from ..reference import (
        ReferenceOptions,
        check_traceable,
        render_reference,
        write_reference,
    )
    from ..reference.keys import finished_reference

    if (args.out is None) == (args.out_dir is None):
        raise SceneError("give either --out (one scene) or --out-dir (one or more scenes)",
                         where="--out")
    if args.out is not None and len(args.scenes) != 1:
        raise SceneError(f"--out takes one scene, got {len(args.scenes)}: use --out-dir",
                         where="--out")
    aovs = tuple(a.strip() for a in args.aov.split(",") if a.strip()) if args.aov else ()
    size = _parse_size(args.size) if args.size else None
    options = ReferenceOptions(spp=args.spp, max_depth=args.depth, antialias=args.antialias,
                               seed=args.seed, variant=args.variant,
                               geometry=args.geometry)
    jobs = []
    for path in args.scenes:  # every scene is checked before any is rendered
        scene = load_scene(path)
        if size is not None:
            scene = scene.with_camera(size=size)
        check_traceable(scene)
        if args.out is not None:
            out = Path(args.out)
            if out.suffix.lower() != ".exr":
                raise SceneError("--out must end in .exr", where=out)
        else:
            out = Path(args.out_dir) / (Path(path).stem + ".exr")
        jobs.append((scene, out))
    rank = int(os.environ.get("RANK", "0"))
    world = max(1, int(os.environ.get("WORLD_SIZE", "1")))
    for scene, out in jobs[rank::world]:
        if not out.resolve().parent.is_dir():
            out.resolve().parent.mkdir(parents=True, exist_ok=True)
        done = finished_reference(out, scene, options, args.spp)
        if done is not None:
            if not args.quiet:
                print(f"{out}: up to date ({done['spp']} spp)")
            continue
        ref = render_reference(scene, options, checkpoint=out.with_name(out.name + ".partial.npz"),
                               progress=not args.quiet, aovs=aovs)
        files = write_reference(ref, out)
        if not args.quiet:
            se = float(ref.stderr.mean())
            print(f"{out}: {ref.meta['spp']} spp, depth {ref.meta['max_depth']}, "
                  f"{ref.meta['rays']} rays, mean standard error {se:.3g}, "
                  f"{ref.meta['seconds']:.1f} s ({ref.meta['variant']}); "
                  f"{', '.join(p.name for p in files[1:])}")
    return 0


def reference_tracer(where: str = "--targets"):
    """The path tracer the dataset generator takes its targets from (``learned`` may not import
    ``relight``, so it is handed in): ``trace(scene, spp, max_depth, seed, checkpoint)`` ->
    :class:`relight.reference.Reference`, pixel-centre rays, Mitsuba's ``llvm_ad_rgb`` backend.
    A one-line error naming what to install when Mitsuba or a libLLVM >= 19 is missing (the
    scalar backend would take hours for a dataset). ``where``: what the error names (the option
    or command that asked for path-traced targets)."""
    import importlib.util

    if importlib.util.find_spec("mitsuba") is None:
        raise RelightError("path-traced targets need Mitsuba 3: pip install -e '.[reference]'",
                           where=where)
    from relight.reference import render

    if render.find_libllvm() is None:
        raise RelightError(f"path-traced targets need libLLVM >= {render.MIN_LLVM} for "
                           "Mitsuba's llvm_ad_rgb backend (apt-get install libllvm19, or set "
                           "DRJIT_LIBLLVM_PATH)", where=where)
    render.load_mitsuba("llvm_ad_rgb")  # ReferenceError (one line) if the backend fails

    def trace(scene, spp: int, max_depth: int, seed: int = 0, checkpoint=None):
        options = render.ReferenceOptions(spp=spp, max_depth=max_depth, seed=seed,
                                          variant="llvm_ad_rgb")
        return render.render_reference(scene, options, checkpoint=checkpoint, progress=False)

    return trace
