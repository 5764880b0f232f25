"""The ``relight`` sub-commands, one function each (``cmd_<name>(args) -> exit code``); the parser
that maps the command line onto them is :mod:`relight.cli`. Torch-side commands import
:mod:`learned` when they run, so ``relight render`` and ``relight view`` work without torch."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from viewer.errors import RelightError, SceneError

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
    from viewer.gl import ContextOptions

    return ContextOptions(software=getattr(args, "software", False))


def cmd_render(args) -> int:
    from viewer.imageio import write_exr, write_png
    from viewer.renderer import Renderer, check_aovs
    from viewer.scene import load_scene, validate_render

    out = Path(args.out)
    if out.suffix.lower() not in (".exr", ".png"):
        raise SceneError("--out must end in .exr (linear radiance) or .png (tone-mapped sRGB)",
                         where=out)
    if not out.resolve().parent.is_dir():
        raise SceneError("output folder does not exist", where=out.parent)
    scene = load_scene(args.scene or _demo_path())
    changes = {k: v for k, v in (("model", args.model), ("samples", args.samples),
                                 ("exposure", args.exposure), ("tonemap", args.tonemap))
               if v is not None}
    for key, value in changes.items():  # checked as a scene file's [render] is, named by option
        validate_render({key: value}, f"--{key}")
    if changes:
        scene = scene.with_render(**changes)
    aovs = [a.strip() for a in args.aov.split(",") if a.strip()] if args.aov else []
    check_aovs(aovs)  # before any GPU work
    size = _parse_size(args.size) if args.size else None

    renderer = Renderer(options=_context_options(args))
    try:
        frame = renderer.render(scene, aovs=tuple(aovs), size=size)
    finally:
        renderer.release()
    # everything is in memory before the first file is written: an error writes nothing
    if out.suffix.lower() == ".exr":
        rgba = frame.radiance if scene.render.display.background == "transparent" else frame.radiance[..., :3]
        write_exr(out, rgba, ["R", "G", "B", "A"][: rgba.shape[2]])
    else:
        keep = 4 if scene.render.display.background == "transparent" else 3
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
    from viewer.gl import Programs, create_context
    from viewer.models import model_info

    if args.model is not None:
        from learned.parity import check_models

        if args.model not in check_models():
            model_info(args.model)  # not a pass-check group (e.g. "splats"): must be a model
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


def cmd_reference(args) -> int:
    """Path-traced references (module :mod:`relight.reference`): one scene to ``--out``, or several
    to ``--out-dir``, this process taking every ``WORLD_SIZE``-th scene from ``RANK`` (torchrun).
    A scene whose finished reference has the same configuration and at least ``--spp`` samples
    is skipped; an interrupted one resumes from ``<out>.partial.npz``."""
    import os

    from viewer.scene import load_scene

    from .reference import (
        ReferenceOptions,
        check_traceable,
        render_reference,
        write_reference,
    )
    from .reference.render import config_key

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
        meta = out.with_suffix(".json")
        if meta.is_file():
            try:
                done = json.loads(meta.read_text())
            except ValueError:
                done = {}
            if done.get("key") == config_key(scene, options) and done.get("spp", 0) >= args.spp:
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


def cmd_info(args) -> int:
    from viewer.gl import create_context, gl_info

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


def cmd_view(args) -> int:
    try:
        import imgui_bundle  # noqa: F401  (before glfw: both must use the same libglfw)
    except ImportError as exc:
        raise RelightError(f"relight view needs imgui-bundle: pip install -e '.[gui]' ({exc})",
                           where="view") from None
    from viewer.scene import load_scene

    from .app.window import Viewer

    if args.frames is not None and args.frames < 1:
        raise SceneError(f"--frames must be at least 1, got {args.frames}", where="--frames")
    shot = Path(args.screenshot) if args.screenshot else None
    if shot is not None:
        if shot.suffix.lower() not in (".png", ".exr"):
            raise SceneError("--screenshot must end in .png (the view) or .exr (linear radiance)",
                             where=shot)
        if not shot.resolve().parent.is_dir():
            raise SceneError("output folder does not exist", where=shot.parent)
    scene = load_scene(args.scene or _demo_path())
    if args.size:
        scene = scene.with_camera(size=_parse_size(args.size))
    viewer = Viewer(scene, offscreen=args.offscreen, options=_context_options(args),
                    title=f"relight view - {Path(scene.source).name if scene.source else 'scene'}")
    try:
        if args.reference:
            viewer.frame()
            if not viewer.load_reference(args.reference):
                raise RelightError(viewer.state.message)
        frames = args.frames
        if frames is None and (args.offscreen or shot is not None):
            frames = 1
        viewer.run(frames=frames)
        if viewer.renders == 0:  # the scene itself failed (a missing mesh, an unknown model)
            raise RelightError(viewer.state.message or "nothing could be rendered")
        if shot is not None:
            viewer.screenshot(shot)
            if not args.quiet:
                print(f"{viewer.frames} frames -> {shot}")
    finally:
        viewer.close()
    return 0


def cmd_bench(args) -> int:
    from .bench.run import BenchConfig, pareto_front, run_bench

    config = BenchConfig(quick=args.quick, frames=args.frames,
                         reference_spp=256 if args.quick else 1024,
                         heldout=tuple(getattr(args, "heldout", None) or ()))
    report = run_bench(args.out, config, fresh=args.fresh, progress=not args.quiet)
    front = pareto_front(report["results"])
    print(f"wrote {args.out}/bench.json, bench.csv, bench.md, pareto.png "
          f"({len(report['results'])} rows)")
    print("Pareto front (fastest first, each more accurate than the previous):")
    for r in front:
        print(f"  {r['scene']:>8} {r['size'][0]}x{r['size'][1]}  {r['model']:<14} "
              f"{r['variant']:<22} {r['ms']:9.2f} ms  {r['psnr']:6.2f} dB")
    for s in report["specialization"]:
        print(f"specialised {s['scene']}: {s['ms_general']:.2f} -> {s['ms_specialized']:.2f} ms "
              f"({s['ms_general'] / s['ms_specialized']:.2f}x), max abs diff {s['max_abs_diff']:.2g}")
    from .bench.truth import truth_front, truth_summary

    summary = truth_summary(report["results"])
    if summary:
        print("Against the path-traced references (mean over scenes; time relative to split-sum):")
        for ref, label in (("truth", "path-traced truth"), ("mc", "converged ggx_mc")):
            print(f"  Pareto front vs {label}:")
            for e in truth_front(summary, ref):
                print(f"    {e['model']:<14} {e['variant']:<24} {e['ms_ratio']:6.2f}x  median rel. "
                      f"error {100 * e[f'median_rel_{ref}']:5.1f} %  |bias| "
                      f"{100 * e[f'abs_bias_{ref}']:5.1f} %")
    if report.get("heldout"):
        print("Against path-traced truth on the held-out datasets (Pareto front, fastest first):")
        for r in report["heldout"]:
            if r["pareto"]:
                print(f"  {r['dataset']:<16} {r['model']:<14} {r['variant']:<26} {r['ms']:8.2f} ms "
                      f"{r['psnr']:6.2f} dB")
    return 0


def _learned(what: str):
    import importlib

    try:
        return importlib.import_module(what)
    except ImportError as exc:
        raise RelightError(f"this command needs torch: pip install -e '.[learned]' ({exc})",
                           where=what) from None


# ``relight train`` options that override a field of learned.train.TrainConfig
TRAIN_OVERRIDES = ("teacher_steps", "shadow_steps", "student_steps", "batch_pixels",
                   "light_samples", "strategy", "student_target", "student_features",
                   "student_output", "student_hidden", "student_indirect",
                   "student_sun", "student_multiscatter", "student_gain_penalty",
                   "teacher_light_input")


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _nonnegative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value >= 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value


def _hidden(text: str) -> tuple[int, ...]:
    """``--student-hidden 32,32`` -> (32, 32)."""
    try:
        widths = tuple(int(w) for w in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"not comma-separated integers: {text!r}") from None
    if not widths or any(w < 1 or w > 256 for w in widths):
        raise argparse.ArgumentTypeError(f"widths must be 1..256, got {text!r}")
    return widths


def cmd_train(args) -> int:
    """Synthetic data (unless --data) -> teacher -> shadow estimator -> distilled student, or
    (--compare-students) the measured comparison of the candidate student designs."""
    over = {k: getattr(args, k) for k in TRAIN_OVERRIDES if getattr(args, k) is not None}
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
    if args.stage == "student" and over.get("student_target") != "target":
        raise RelightError("the student stage alone learns from the dataset's targets: add "
                           "--student-target target (a distilled student needs the teacher)",
                           where="--stage")
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


def _data_config(args):
    """``relight data``'s configuration: ``--preset`` with ``--count``, ``--size``, ``--spp`` and
    ``--seed`` overriding its fields (none given: exactly the preset's dataset)."""
    try:
        from learned.data.presets import preset_config
    except ImportError as exc:
        raise RelightError(f"relight data needs the 'reference' extra: pip install -e "
                           f"'.[reference]' ({exc})", where="data") from None
    return preset_config(args.preset, count=args.count, size=args.size, reference_spp=args.spp,
                         seed=args.seed)


def cmd_data(args) -> int:
    """(Re)generate a named dataset (:mod:`learned.data.presets`: the path-traced training truth
    and the two held-out sets) under OUT: resumable (finished samples are kept, an interrupted
    path-traced target resumes from its checkpoint), sharded over torchrun ranks (sample i by
    rank i % WORLD_SIZE, every rank returning once all are written)."""
    from learned.data.generator import generate, split_of
    from learned.data.presets import PRESETS

    config = _data_config(args)  # checked before Mitsuba loads or anything is written
    tracer = reference_tracer(where="relight data")
    out = generate(args.out, config, progress=not args.quiet, shard=True, tracer=tracer)
    if args.quiet or out.get("rank", 0) != 0:
        return 0
    preset = PRESETS[args.preset]()
    splits = {s: sum(split_of(i) == s for i in range(config.count))
              for s in ("train", "val", "test")}
    by = " by rank 0" if "rank" in out else ""
    print(f"{args.out}: preset {args.preset}, {config.count} samples "
          f"({', '.join(f'{n} {s}' for s, n in splits.items() if n)}; {out['written']} written, "
          f"{out['kept']} kept{by}), {config.size}x{config.size}, {config.reference_spp} spp "
          "path-traced")
    options = (("size", "size"), ("spp", "reference_spp"), ("seed", "seed"))
    changed = [f"--{o} {getattr(config, k)}" for o, k in options
               if getattr(config, k) != getattr(preset, k)]
    if changed:
        print(f"  {', '.join(changed)}: not the preset's dataset (its scores are not comparable "
              "with the README's)")
    elif config.count < preset.count:
        print(f"  --count {config.count}: the first {config.count} of the preset's "
              f"{preset.count} samples")
    elif config.count > preset.count:
        print(f"  --count {config.count}: the preset's {preset.count} samples and "
              f"{config.count - preset.count} more")
    if args.preset == "truth-train":
        print(f"next: relight train --data {args.out} --student-target target ... "
              f"(assets/weights/README.md); relight eval {args.out} --split test")
    else:
        print(f"next: relight eval {args.out} --split all")
        print(f"      relight bench --out runs/bench --heldout {args.out}")
    return 0
