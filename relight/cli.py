"""``relight``: the command line of the relighting workbench.

    relight render [SCENE.toml | ASSET...] --out FILE [--model M] [--samples N] [--size WxH]
                 [--aov a,b] [--ssaa N] [--env FILE|sky|studio|white] [--up AXIS] [--floor [slab]]
                 [--set KEY=VALUE ...]
    relight scene ASSET... [--env E] [--up AXIS] [--floor [slab]] [--model M] [--size WxH]
                 [--set KEY=VALUE ...] > scene.toml
    relight parity [--model M] [--json]
    relight decompose IN.ply --out OUT.ply [--views V] [--iterations N] [--checkpoint FILE]
    relight info [--json] [--weights [FILE ...]]
    relight train [--data DIR] [--out RUN] [--quick] [--stage S] [--seed N] [--install]
                  [--compare-students]
    relight train --stage shadow_net --data DIR [--shadow-extra-data DIR ...]
                  [--shadow-val-data DIR ...] [--shadow-degrade L,L] [--shadow-geometry G]
    relight data OUT --preset NAME [--count N] [--size S] [--spp N] [--seed N]
                 (NAME: truth-train, heldout-kinds, heldout-env, shadow-extra, shadow-val,
                 shadow-blocks, shadow-blocks-val)
    relight data OUT --protocol [--count N] [--size S] [--spp N] [--seed N]
    relight eval DATA [--split test] [--by kind|environment] [--teacher-weights FILE]
                 [--shadow-weights FILE] [--json]
    relight eval DATA --factors [--split val] [--weights NAME=FILE ...]
    relight eval DATA --protocol [--seeds 0,1,2] [--degrade LEVEL] [--student-steps N]
                 [--weights NAME=FILE]
    relight graph [SCENE.toml] [--then KEY=VALUE] [--dot FILE] [--json]
    relight view [SCENE.toml | ASSET...] [--frames N] [--screenshot FILE [--screenshot-ui]]
                 [--offscreen] [--size WxH] [--window WxH] [--fit-window] [--model M] [--view V]
                 [--env E] [--up AXIS] [--floor [slab]] [--set KEY=VALUE ...]

``--set KEY=VALUE`` (repeatable) changes any ``[render]`` setting by its scene-file key, the
value read as TOML (``--set raytrace=true --set ssao_rays=16 --set tonemap=aces``).

An ASSET is a glTF/GLB, OBJ, STL, OFF or PLY mesh, a splat cloud (3DGS PLY, .splat) or an image
G-buffer stack (a folder, a 12-channel .exr): the scene is made for it (viewer.scene.assets).

Errors a user can cause print one line, ``relight: error: <file>: <problem>``, and exit with 2,
writing nothing; warnings print one line each, ``relight: warning: <file>: <problem>`` (what was
assumed about an asset: ``relight: note: ...``).
"""
from __future__ import annotations

import argparse
import sys
import warnings

from viewer.errors import AssetNote, RelightError

from . import gallery
from . import graph as graph_command
from .commands import eval as eval_command
from .commands import (
    _fraction,
    _hidden,
    _nonnegative_float,
    _positive_int,
    cmd_bench,
    cmd_data,
    cmd_decompose,
    cmd_info,
    cmd_parity,
    cmd_reference,
    cmd_render,
    cmd_train,
    cmd_view,
)
from .commands.scene import add_asset_arguments, cmd_scene, glue_up_values, model_help
from .commands.train import add_shadow_net_arguments


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="relight", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("render", help="render a scene headlessly to EXR (linear) or PNG")
    p.add_argument("scene", nargs="*", metavar="SCENE.toml|ASSET",
                   help="a scene TOML (default: the built-in demo), or asset files (glTF/GLB, "
                        "OBJ, STL, OFF, PLY mesh or splats, .splat, G-buffer stack), framed")
    p.add_argument("--out", required=True, help="output .exr (linear radiance) or .png")
    p.add_argument("--model", help=model_help("shading model (overrides [render] model)"))
    p.add_argument("--samples", type=int, help="samples per pixel for sampling models")
    p.add_argument("--size", help="WxH (overrides [camera] size)")
    p.add_argument("--aov", help="comma-separated G-buffer channels written to <out>.<name>.exr")
    p.add_argument("--exposure", type=float, help="EV stops (PNG only)")
    p.add_argument("--tonemap", help="pbr_neutral (default) | aces | agx | reinhard | none "
                   "(PNG only)")
    p.add_argument("--aa", help="fxaa (default) | none: anti-aliasing of the PNG")
    p.add_argument("--ssaa", type=int, metavar="N",
                   help="supersample: render at N x the size and box-average the radiance (1-8)")
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    add_asset_arguments(p, model=False, size=False)
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("scene", help="print the scene made for asset files (TOML) to continue from",
                       description="Print, as TOML on stdout, the scene relight render and relight "
                       "view make for asset files with the same options: edit it and render it "
                       "(relight render scene.toml) for everything the options do not say.")
    p.add_argument("scene", nargs="+", metavar="ASSET|SCENE.toml", help="asset files (or a scene)")
    add_asset_arguments(p)
    p.set_defaults(func=cmd_scene)

    p = sub.add_parser("reference", help="path-traced ground truth with Mitsuba 3 and our BSDF",
                       description="Path-trace scenes with Mitsuba 3 (our BSDF as a Mitsuba "
                       "plugin, the rasteriser's per-pixel rays): <out>.exr (mean radiance, "
                       "alpha = coverage), <out>.stderr.exr (per-pixel standard error), "
                       "<out>.json. Several scenes shard over torchrun ranks "
                       "(torchrun --nproc_per_node=N -m relight reference A.toml B.toml "
                       "--out-dir DIR); finished scenes are skipped and interrupted ones resume.")
    p.add_argument("scenes", nargs="+", help="scene TOML files")
    p.add_argument("--out", help="output .exr (one scene)")
    p.add_argument("--out-dir", help="output folder, <scene stem>.exr each (several scenes)")
    p.add_argument("--spp", type=_positive_int, default=1024, help="samples per pixel (1024)")
    p.add_argument("--depth", type=_positive_int, default=6,
                   help="Mitsuba path depth (2 = direct light only; default 6)")
    p.add_argument("--antialias", action="store_true",
                   help="rays jittered over each pixel (default: pixel-centre rays, comparable "
                        "pixel by pixel with the rasteriser)")
    p.add_argument("--aov", help="comma-separated first-hit AOVs: normal, depth")
    p.add_argument("--size", help="WxH (overrides [camera] size)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--variant", help="Mitsuba variant (default llvm_ad_rgb, else scalar_rgb)")
    p.add_argument("--geometry", default="mesh", choices=("mesh", "analytic"),
                   help="mesh (default): the rasteriser's own triangles, so a difference is "
                        "shading alone; analytic: exact spheres")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_reference)

    p = sub.add_parser("parity", help="compare every GLSL function and pass with its torch twin")
    p.add_argument("--model", help="only this shading model's passes")
    p.add_argument("--json", action="store_true")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--skip", action="append", default=[], metavar="CHECK",
                   help="leave out this pass check (repeatable; e.g. model:neural_teacher)")
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    p.set_defaults(func=cmd_parity)

    p = sub.add_parser("bench", help="frame time and error of every model and knob -> tables, plot")
    p.add_argument("--out", required=True, help="output folder (bench.json, .csv, .md, pareto.png)")
    p.add_argument("--quick", action="store_true", help="one small size, fewer knobs (minutes)")
    p.add_argument("--frames", type=int, default=10, help="timed frames per case (default 10)")
    p.add_argument("--fresh", action="store_true", help="ignore rows measured by an earlier run")
    p.add_argument("--heldout", action="append", metavar="DATA",
                   help="also score every model against path-traced truth on this held-out "
                        "dataset (relight eval DATA --split all) and mark its Pareto front "
                        "(repeatable; needs torch)")
    p.add_argument("--trade", action="append", metavar="DATA",
                   help="the shadow_trade suite's protocol dataset: every visibility option on "
                        "its val split against truth, at equal time and accuracy (repeatable)")
    p.add_argument("--suite", action="append", metavar="NAME",
                   help="measure only this extra suite (e.g. shadow_truth, penumbra) -> "
                        "OUT/NAME.json and NAME.md (repeatable)")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("decompose", help="baked-colour splats -> per-splat materials + cubemap "
                       "light (thesis eqs. 6.11-6.12, 6.24-6.27)")
    p.add_argument("input", nargs="?", help="splat PLY (3DGS layout); omit with --synthetic")
    p.add_argument("--out", required=True, help="output relightable PLY (+ <out>.light.exr)")
    p.add_argument("--synthetic", type=int, default=0, metavar="N",
                   help="decompose a generated N-splat scene with known truth and report the "
                        "relighting error")
    p.add_argument("--views", type=int, default=8)
    p.add_argument("--size", type=int, default=64, help="view resolution (square)")
    p.add_argument("--iterations", type=int, default=300)
    p.add_argument("--checkpoint", help="checkpoint file (resumed when it exists)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_decompose)

    p = sub.add_parser("train", help="train the neural shader: data, teacher, shadow, student",
                       description="Train the neural shader: synthetic data (unless --data), "
                       "teacher, shadow estimator, distilled student. Several processes: "
                       "torchrun --nproc_per_node=N -m relight train ... (DistributedDataParallel, "
                       "gloo on CPU, NCCL on GPUs).")
    p.add_argument("--data", help="dataset root in the FFHQ256-PBR layout (default: generate a "
                                  "synthetic one under OUT/data)")
    p.add_argument("--out", default="runs/quick", help="run folder (checkpoints, logs, weights)")
    p.add_argument("--quick", action="store_true", help="small networks and few steps (minutes)")
    p.add_argument("--stage", default="all",
                   choices=("all", "teacher", "shadow", "student", "shadow_net"),
                   help="every stage (default), the teacher alone, the teacher and the "
                        "shadow UNet (OUT/shadow_final.pt; no student), or the student alone "
                        "(with --student-target target; --install then installs it alone); "
                        "shadow_net: the viewer's neural shadow estimator alone, on --data's "
                        "targets (OUT/shadow_net.safetensors, for [render] shadow_net; "
                        "--shadow-steps, default 1000)")
    p.add_argument("--seed", type=int, metavar="N",
                   help="the training seed (default 0): network initialisation and batches")
    p.add_argument("--teacher-steps", type=_positive_int, metavar="N")
    p.add_argument("--shadow-steps", type=_positive_int, metavar="N")
    add_shadow_net_arguments(p)  # --shadow-extra-data, -val-data, -degrade, -geometry
    p.add_argument("--student-steps", type=_positive_int, metavar="N")
    p.add_argument("--batch-pixels", type=_positive_int, metavar="N",
                   help="foreground pixels per step (teacher and student)")
    p.add_argument("--light-samples", type=_positive_int, metavar="N",
                   help="light directions per pixel while training the teacher")
    p.add_argument("--strategy", choices=("uniform", "cosine", "env"),
                   help="how the teacher samples light directions (default env)")
    p.add_argument("--teacher-light-input", choices=("on", "off"),
                   help="whether the teacher sees the light's radiance log(1 + L_in) as an input "
                        "(default off, the shipped teacher's: rho from material and geometry "
                        "only, exactly linear in the light; on: the thesis's eq. 4.2)")
    p.add_argument("--student-target", choices=("teacher", "target"),
                   help="what the student learns from: the dataset's targets (default, the "
                        "shipped student's: truth for traced data) or the teacher x shadow map "
                        "(the thesis's distillation)")
    p.add_argument("--student-output", choices=("free6", "pbr3", "split3"),
                   help="the student's output form (default split3, the shipped design: "
                        "corrections of the split-sum model, which it starts from)")
    p.add_argument("--student-hidden", type=_hidden, metavar="W,W",
                   help="the student's hidden layer widths (default 32,32)")
    p.add_argument("--student-features",
                   choices=("base", "dfg", "ssao", "ssao-env", "vis", "dfg-vis"),
                   help="the student's inputs (default ssao-env: the material, n.v and how "
                        "bright the environment is from below, with the SSAO pass's occlusion "
                        "only as the diffuse factor, as the classical models apply it; ssao: "
                        "without the environment; vis: + the pass's visibility of the "
                        "environment's light, which invents shadows on real assets)")
    p.add_argument("--student-indirect", choices=("none", "factor"),
                   help="whether the student learns a factor on the screen-space indirect light "
                        "(default factor: a second small network on the same inputs, "
                        "starting at the classical one-bounce term; the renderer then runs the "
                        "indirect pass)")
    p.add_argument("--student-sun", action=argparse.BooleanOptionalAction, default=None,
                   help="a split3 student whose base shades the environment's sun analytically, "
                        "as ggx_split_sum does (the IBL without the sun + the sun as a light, "
                        "with the student's corrections; weights architecture \"sun\": true; "
                        "default on)")
    p.add_argument("--student-multiscatter", action=argparse.BooleanOptionalAction, default=None,
                   help="a split3 student whose base has ggx_split_sum's multiple-scattering "
                        "compensation, the classical model's default (weights architecture "
                        "\"multiscatter\": true; default on)")
    p.add_argument("--student-gain-penalty", type=_nonnegative_float, metavar="W", default=None,
                   help="add W x how far the student's direct-light corrections brighten its "
                        "split-sum base to its loss (default 1, the shipped student's; 0: off)")
    p.add_argument("--student-direct-penalty", type=_nonnegative_float, metavar="W", default=None,
                   help="add W x the squared distance of the student's direct-light corrections "
                        "from its split-sum base, either way, to its loss (default 100, the "
                        "shipped student's; 0: off)")
    p.add_argument("--student-visibility", metavar="FILE", default=None,
                   help="a shadow estimator's weights file whose V takes SSAO's O(x) place in "
                        "the student's frames: a student for [render] shadow_net_use = "
                        "\"visibility\" (default: SSAO's O(x), the shipped student's)")
    p.add_argument("--targets", choices=("rasteriser", "reference"), default="rasteriser",
                   help="where the generated dataset's targets come from: the rasteriser's "
                        "ggx_mc (default) or path-traced truth (relight reference; needs the "
                        "'reference' extra and libLLVM >= 19; OUT/data-truth, shards by rank)")
    p.add_argument("--count", type=_positive_int, metavar="N",
                   help="samples of the dataset --targets reference generates (default 40, the "
                        "quick dataset's; the shipped student's: 480)")
    p.add_argument("--reference-spp", type=_positive_int, metavar="N", default=256,
                   help="path-traced samples per pixel of --targets reference (default 256)")
    p.add_argument("--install", action="store_true",
                   help="copy the exported weights to assets/weights (the shipped defaults)")
    p.add_argument("--compare-students", action="store_true",
                   help="distil every candidate student design from the quick teacher and write "
                        "the measured table OUT/students/compare.{json,md} (--install: to "
                        "assets/weights/students, read by relight bench)")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("data", help="(re)generate the path-traced training or held-out datasets",
                       description="Generate a named dataset with path-traced targets (needs the "
                       "'reference' extra and libLLVM >= 19): the training truth of the shipped "
                       "student or one of the two held-out sets that relight eval --split all and "
                       "relight bench --heldout score. A preset reproduces its dataset sample for "
                       "sample (same seeds). Re-running skips finished samples and resumes an "
                       "interrupted one; several processes shard the samples (torchrun "
                       "--nproc_per_node=N -m relight data OUT --preset NAME: sample i by rank "
                       "i % WORLD_SIZE).")
    p.add_argument("out", help="dataset folder (created; an existing one of the same "
                               "configuration is completed)")
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--protocol", action="store_true",
                   help="the protocol's dataset instead of a preset: train / val / test split by "
                        "scene seed and by environment (learned/protocol/data.py; --count gives "
                        "the train split's size, val and test a quarter and two fifths of it)")
    which.add_argument("--preset", metavar="NAME",
                   help="truth-train: the path-traced training truth (480 samples; the shipped "
                        "student's); heldout-kinds: held-out scene kinds and environment (40 "
                        "samples); heldout-env: the training scene kinds under a held-out "
                        "environment (40 samples); shadow-extra / shadow-val: the shadow "
                        "estimator's extra training (160) / second validation (60) scenes under "
                        "training HDRIs; shadow-blocks / shadow-blocks-val: made objects (boxes, "
                        "panels, pipes, arches) for it, 160 / 40 - learned/data/presets.py")
    p.add_argument("--count", type=_positive_int, metavar="N",
                   help="samples (default the preset's; fewer: its first N samples)")
    p.add_argument("--size", type=_positive_int, metavar="S",
                   help="square image size (default the preset's: 64, shadow-*: 96; changes "
                        "every sample: not the preset's dataset any more)")
    p.add_argument("--spp", type=_positive_int, metavar="N",
                   help="path-traced samples per pixel of the targets (default the preset's: "
                        "256, shadow-*: 64; changes the targets' noise: not the preset's "
                        "dataset any more)")
    p.add_argument("--seed", type=int, metavar="N",
                   help="random seed (default the preset's; another seed draws other scenes: "
                        "not the preset's held-out set any more)")
    p.add_argument("--sunless", type=_fraction, metavar="F",
                   help="the share of samples lit without the environment's compact sun and "
                        "lamps (sun_strength 0; default 0; 1: the preset's scenes, all sunless)")
    p.add_argument("--ground", type=_fraction, metavar="F",
                   help="the share of samples whose environment's lower hemisphere is a bright "
                        "Lambertian ground (albedo 0.2-0.9) lit by its sky (default 0)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(func=cmd_data)

    eval_command.add_parser(sub)  # relight eval: relight/commands/eval.py

    p = sub.add_parser("info", help="GL renderer, version, extensions, float target precision")
    p.add_argument("--json", action="store_true")
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    p.add_argument("--weights", nargs="*", metavar="FILE",
                   help="instead: where neural-shader weights files come from (command, seed, "
                        "dataset hash, val / test scores; default the shipped student and "
                        "teacher)")
    p.set_defaults(func=cmd_info)

    from viewer.models import MODELS
    from viewer.passes.debug_view import VIEWS

    p = sub.add_parser("view", help="the interactive viewer (glfw + Dear ImGui)")
    p.add_argument("scene", nargs="*", metavar="SCENE.toml|ASSET",
                   help="a scene TOML (default: the built-in demo), or asset files, framed")
    p.add_argument("--frames", type=int, help="run exactly N frames, then exit")
    p.add_argument("--screenshot", help="after the last frame, save the view (.png) or the "
                   "linear radiance (.exr)")
    p.add_argument("--screenshot-ui", action="store_true",
                   help="with --screenshot FILE.png: the whole window, the panel and overlay "
                        "drawn, at the window's size")
    p.add_argument("--model", choices=tuple(MODELS), metavar="MODEL",
                   help="shading model (overrides [render] model): " + ", ".join(MODELS))
    p.add_argument("--view", choices=VIEWS, metavar="VIEW",
                   help="what the view shows: " + ", ".join(VIEWS))
    p.add_argument("--offscreen", action="store_true",
                   help="no display: glfw's Null platform with an EGL context")
    p.add_argument("--size", help="WxH render size (overrides [camera] size)")
    p.add_argument("--window", metavar="WxH",
                   help="window size (default: the render 1:1 beside the panel, at most "
                        "1600x1000)")
    p.add_argument("--fit-window", action="store_true",
                   help="the render size follows the area beside the panel (the camera's "
                        "aspect follows the window)")
    p.add_argument("--reference", help="a linear EXR/HDR render for the difference views")
    add_asset_arguments(p, model=False, size=False)
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_view)

    gallery.add_parser(sub)  # relight gallery: relight/gallery/
    graph_command.add_parser(sub)  # relight graph: relight/graph.py
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(glue_up_values(sys.argv[1:] if argv is None else argv))
    shown, formatted = warnings.showwarning, warnings.formatwarning
    warnings.showwarning, warnings.formatwarning = _show_warning, _format_warning
    try:
        return args.func(args)
    except RelightError as exc:
        print(f"relight: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        return 130
    finally:
        warnings.showwarning, warnings.formatwarning = shown, formatted


def _format_warning(message, category, filename, lineno, line=None) -> str:
    """A warning as the CLI prints it: one line, no source location (the message names the
    file it is about); what was assumed about an asset is a note."""
    label = "note" if issubclass(category, AssetNote) else "warning"
    return f"relight: {label}: {' '.join(str(message).split())}\n"


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    (file or sys.stderr).write(_format_warning(message, category, filename, lineno))


if __name__ == "__main__":
    sys.exit(main())
