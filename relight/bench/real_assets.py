"""Issue 38's real-asset criterion as a bench: every bundled glTF model on a floor under every
bundled HDRI, rendered with the neural student and with split-sum given the same visibility
evidence, scored against the path-traced truth.

``python -m relight.bench.real_assets [--out DIR] [--cache DIR] [--spp N] [--size WxH] [--quick]
[--estimator NAME=FILE] [--student NAME=FILE] [--variant CASE KEY=VALUE ...]`` (also ``relight
bench --suite real_assets``) writes ``real_assets.json``, ``real_assets.md`` (the table and a
summary line counting the failures) and ``real_assets.png`` (a contact sheet) into ``--out``.

**Scenes** (:func:`asset_scene`): each model of :data:`ASSETS` opened as ``relight render MODEL
--env HDRI --floor slab`` opens it (:func:`viewer.scene.assets.open_assets`: upright, framed by the
auto camera, a floor touching its lowest point) under each ``assets/environments/*.exr`` at
rotation 0, its compact sun as it is and, where it has one, again without it (:func:`lightings`:
``--sun-strength 0``, scenes named ``MODEL/HDRI-nosun``). The floor is the matte grey *slab*, not
the default *catcher*: the catcher draws only the shadows it receives over the environment, which
the path tracer has no counterpart for (it would trace a white Lambertian plane).

**Cases** (:mod:`.real_assets_cases`): split-sum and the student with the default render
(``raytrace = true``: ray-traced visibility and bounce), both screen-space (``raytrace = false``,
SSAO + indirect light, the bounce denoised as by default), the student before this one (which read
S(x): :func:`~.real_assets_cases.sx_student_file`) screen-space, and split-sum screen-space with
the mesh shadow estimator (``assets/weights/shadow_net_mesh.safetensors``) in the frame it was
trained on (:func:`viewer.neural.shadow_net.frame_settings`); and split-sum and the student
screen-space with the estimator's visibility in place of SSAO's occlusion and the student's S(x)
(``shadow_net_use = "visibility"``: the issue's "usable by every model"). Each non-split-sum case
is judged against the split-sum case with the same visibility evidence
(:attr:`~.real_assets_cases.Case.baseline`). Beside them, candidate estimator files
(``--estimator``), candidate student files (``--student``: ``neural NAME, rays``, ``neural
NAME, screen`` and ``neural NAME, estimator's V``, judged as the shipped student's cases) and
*variants* (``--variant``, :func:`~.real_assets_cases.variant_case`): a case again with ``[render]`` settings changed,
judged against that case, so a setting's cost against the truth (``ray_scale=2`` on the rays)
is a row of the same table. **The splat capture** (:mod:`.real_assets_splats`): the plasma gun
tiled with splats of its true materials on the same floor, drawn the same eight ways (rays see
the splats' Gaussians: :mod:`viewer.raytrace.splat_proxies`), against the gun's own truth;
its failures are counted apart ("(splats)").

**Truth**: Mitsuba 3 with our BSDF (:mod:`relight.reference`), cached as the gallery caches it
(:func:`relight.gallery.panels.cached_truth`: one file per scene under ``<out>/cache``, keyed by
everything that changes the image), so a second run only rasterises.

**Per row** (:mod:`relight.bench.real_assets_metrics` has the measures and their tolerances):
PSNR, median relative error and energy bias (:func:`relight.reference.compare.score`); the
floor's speckle beside the reference's own and split-sum's; the invented-shadow fraction; and a
verdict on the issue's three conditions.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from .real_assets_report import machine_info, markdown, summary, write
from .real_assets_metrics import (
    PSNR_TOL,
    SHADOW_MODEL_DARKER,
    SHADOW_TOL,
    SHADOW_TRUTH_DARKER,
    SPECKLE_TOL,
    floor_mask,
    invented_shadow,
    relative_difference,
    speckle,
    verdict,
)
from .real_assets_cases import cases
from .real_assets_splats import splat_cases, splat_scenes

from viewer.errors import RelightError

# (name, glTF file under assets/models): every bundled model (cge_base_level is a small diorama
# standing on its own ground; the reference traces its fence's MASK as a cut-out and the
# booth's BLEND alpha as stochastic coverage, where the rasteriser blends the booth in its
# forward pass and its rays leave it out)
ASSETS: tuple[tuple[str, str], ...] = (
    ("cge_plasma_gun", "cge_plasma_gun/plasma.gltf"),
    ("texture_transform_test", "texture_transform_test/TextureTransformTest.gltf"),
    ("cge_base_level", "cge_base_level/levels/base_level.gltf"),
)
FLOOR = "slab"
DEFAULT_SIZE = (160, 120)
DEFAULT_SPP = 256
# assets, environments, spp of --quick: the gun under lobby (no sun) and under sky with its sun
# and without it (three scenes: every kind of lighting the full matrix judges)
QUICK = (("cge_plasma_gun",), ("lobby", "sky"), 64)
SUNLESS = "-nosun"  # the name suffix of an HDRI's variant without its compact sun
def environments() -> list[tuple[str, Path]]:
    """Every bundled HDRI, ``(name, path)``, sorted by name."""
    from assets import ASSET_ROOT

    return [(p.stem, p) for p in sorted((ASSET_ROOT / "environments").glob("*.exr"))]


def lightings(envs: list[tuple[str, Path]], sunless: bool = True
              ) -> list[tuple[str, Path, float]]:
    """``(name, HDRI, sun_strength)``: each of ``envs`` as it is and, where it has a compact sun
    (:func:`viewer.environment.sun.extract_lights` finds one), also without it, named
    ``NAME-nosun`` (``--sun-strength 0``: the sky the sun stood in); a map without one (lobby)
    has no second variant, it would be the same map."""
    from viewer.environment.maps import EnvironmentSpec, load_environment
    from viewer.environment.sun import extract_lights

    out = []
    for name, path in envs:
        out.append((name, path, 1.0))
        if sunless and extract_lights(load_environment(EnvironmentSpec(path=str(path))))[1]:
            out.append((f"{name}{SUNLESS}", path, 0.0))
    return out


def asset_scene(model: str | Path, env: Path, size: tuple[int, int], sun_strength: float = 1.0):
    """``relight render MODEL --env ENV --floor slab --size WxH [--sun-strength S]``'s scene
    (rotation 0)."""
    from assets import ASSET_ROOT
    from viewer.scene.assets import open_assets

    path = Path(model) if Path(model).is_absolute() else ASSET_ROOT / "models" / model
    scene = open_assets([path], env=str(env), floor=FLOOR, size=size).scene
    return scene if sun_strength == 1.0 else scene.with_environment(sun_strength=sun_strength)


@dataclass(frozen=True)
class Options:
    out: Path = Path("runs/real_assets")
    cache: Path | None = None  # None: <out>/cache
    size: tuple[int, int] = DEFAULT_SIZE
    spp: int = DEFAULT_SPP
    assets: tuple[str, ...] | None = None        # names of ASSETS (None: all)
    environments: tuple[str, ...] | None = None  # HDRI names (None: all)
    sunless: bool = True  # each HDRI with a compact sun also without it (lightings)
    # candidate estimator files scored beside the shipped one: (name, path), --estimator
    estimators: tuple[tuple[str, str], ...] = ()
    # candidate student files scored beside the shipped one: (name, path), --student
    students: tuple[tuple[str, str], ...] = ()
    # cases again with [render] settings changed: (case label, settings), --variant
    variants: tuple[tuple[str, tuple[tuple[str, object], ...]], ...] = ()
    progress: bool = True

    @classmethod
    def quick(cls, **changes) -> Options:
        assets, envs, spp = QUICK
        return cls(**({"assets": assets, "environments": envs, "spp": spp} | changes))


def scene_rows(renderer, name: str, scene, truth, case_list) -> tuple[list[dict], dict]:
    """The rows of one scene (one per case, in order) and its display tiles by case label (and
    ``"reference"``)."""
    from relight.gallery.images import display
    from relight.reference.compare import coverage_mask, score

    radiance, floors = {}, None
    for case in case_list:
        frame = renderer.render(scene.with_render(**case.render),
                                aovs=("normal", "depth") if floors is None else ())
        radiance[case.label] = frame.radiance
        if floors is None:  # the floor from the first case's G-buffer (every case draws the same)
            floors = floor_mask(frame, scene)
    ref_lum_speckle = speckle(truth.radiance, floors)
    rows = []
    for case in case_list:
        img = radiance[case.label]
        mask = coverage_mask(img, truth)
        s = score(img, truth, mask)
        row = {"scene": name, "case": case.label, "psnr_db": round(s.psnr, 2),
               "median_rel_%": round(100 * s.median_rel, 2), "bias_%": round(100 * s.bias, 2),
               "pixels": s.pixels, "floor_pixels": int(floors.sum()),
               "speckle": round(speckle(img, floors), 5),
               "speckle_reference": round(ref_lum_speckle, 5)}
        if case.baseline is not None:
            base = radiance[case.baseline]
            row["baseline"] = case.baseline
            row["speckle_baseline"] = round(speckle(base, floors), 5)
            row["invented_shadow_%"] = round(100 * invented_shadow(img, base, truth.radiance,
                                                                   mask), 3)
            row["differs_%"] = round(100 * relative_difference(img, base, mask), 3)
        rows.append(row)
    by_label = {r["case"]: r for r in rows}
    for row in rows:
        if "baseline" in row:
            base_row = by_label[row["baseline"]]
            row["psnr_gain_db"] = round(row["psnr_db"] - base_row["psnr_db"], 2)
            row.update(verdict(row, base_row))
    tiles = {label: display(img) for label, img in radiance.items()}
    tiles["reference"] = display(truth.radiance)
    return rows, tiles


def run(options: Options = Options(), renderer=None, command: str = "") -> dict:
    """Render, score and write the whole matrix (module docstring); returns the report."""
    from relight.gallery.cases import GalleryOptions
    from relight.gallery.panels import cached_truth
    from viewer.renderer import Renderer

    t0 = time.perf_counter()
    out = Path(options.out)
    out.mkdir(parents=True, exist_ok=True)
    cache = Path(options.cache) if options.cache else out / "cache"
    truth_options = GalleryOptions(cache=cache, progress=options.progress)
    log = (lambda m: print(f"real_assets: {m}", file=sys.stderr, flush=True)) \
        if options.progress else (lambda m: None)
    assets = [a for a in ASSETS if options.assets is None or a[0] in options.assets]
    envs = lightings([e for e in environments() if options.environments is None
                      or e[0] in options.environments], options.sunless)
    case_list = cases(options.estimators, options.variants, options.students)
    own = renderer is None
    renderer = Renderer() if own else renderer
    rows, sheet, truths = [], [], {}
    try:
        with warnings.catch_warnings():
            # the gun's skin and animations are ignored (bind pose); a few degenerate triangles
            warnings.filterwarnings("ignore", message=".*ignored \\(not supported\\).*")
            warnings.filterwarnings("ignore", message=".*degenerate or not finite.*")
            for asset, file in assets:
                for env_name, env_path, sun in envs:
                    name = f"{asset}/{env_name}"
                    scene = asset_scene(file, env_path, options.size, sun)
                    log(f"{name}: truth ({options.spp} spp)")
                    truth = cached_truth(scene, f"{asset}_{env_name}", truth_options,
                                         options.spp)
                    truths[name] = {k: truth.meta.get(k) for k in ("spp", "seconds", "variant")}
                    log(f"{name}: rasterising {len(case_list)} cases")
                    scene_r, tiles = scene_rows(renderer, name, scene, truth, case_list)
                    rows += scene_r
                    sheet.append((name, tiles))
            for name, scene, truth in splat_scenes(options, envs, cache, dict(ASSETS),
                                                   asset_scene):
                log(f"{name}: rasterising the splat capture")
                scene_r, tiles = scene_rows(renderer, name, scene, truth, splat_cases(case_list))
                rows += [r | {"geometry": "splats"} for r in scene_r]
                sheet.append((name, tiles))
        machine = machine_info(renderer)
    finally:
        if own:
            renderer.release()
    report = {"command": command, "seconds": round(time.perf_counter() - t0, 1),
              "size": list(options.size), "spp": options.spp, "floor": FLOOR,
              "machine": machine, "truth": truths,
              "cases": [{"label": c.label, "render": c.render, "baseline": c.baseline}
                        for c in case_list],
              "tolerances": {"speckle_ratio": SPECKLE_TOL, "invented_shadow": SHADOW_TOL,
                             "model_darker": SHADOW_MODEL_DARKER,
                             "truth_darker": SHADOW_TRUTH_DARKER, "psnr_db": PSNR_TOL},
              "rows": rows, "summary": summary(rows)}
    write(report, sheet, out, [c.label for c in case_list])
    return report


def suite_rows(renderer, scenes, config, cache) -> list[dict]:
    """``relight bench --suite real_assets``: the matrix (``--quick``: :data:`QUICK`), its
    truth cached in ``cache/real_assets`` and its files written beside ``bench``'s."""
    opts = Options(out=cache.parent / "real_assets", cache=cache / "real_assets")
    opts = Options.quick(out=opts.out, cache=opts.cache) if config.quick else opts
    report = run(opts, renderer=renderer, command="relight bench --suite real_assets")
    return report["rows"]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m relight.bench.real_assets",
                                description="Issue 38's real-asset criterion: every bundled glTF "
                                "on a floor under every bundled HDRI, neural and split-sum with "
                                "the same visibility, against the path-traced truth.")
    p.add_argument("--out", default="runs/real_assets", help="output folder (truth cached in "
                   "OUT/cache)")
    p.add_argument("--spp", type=int, help=f"truth samples per pixel (default {DEFAULT_SPP}; "
                   f"--quick {QUICK[2]})")
    p.add_argument("--size", help=f"WxH (default {DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]})")
    p.add_argument("--quick", action="store_true", help="one asset under lobby and sky (with its "
                   "sun and without), 64 spp")
    p.add_argument("--estimator", action="append", default=[], metavar="NAME=FILE",
                   help="also score this shadow-estimator file, as the shipped one is "
                        "('split-sum, screen + NAME'; repeatable)")
    p.add_argument("--student", action="append", default=[], metavar="NAME=FILE",
                   help="also score this student file, as the shipped one is ('neural NAME, "
                        "rays', 'neural NAME, screen' and 'neural NAME, estimator\'s V'; "
                        "repeatable)")
    p.add_argument("--variant", action="append", default=[], nargs="+",
                   metavar=("CASE", "KEY=VALUE"), help="also score CASE (a case's label, e.g. "
                   "'split-sum, rays') with these [render] settings changed, judged against "
                   "CASE itself (e.g. --variant 'split-sum, rays' ray_scale=2; repeatable)")
    p.add_argument("--cache", help="the truth cache folder (default OUT/cache)")
    p.add_argument("-q", "--quiet", action="store_true")
    a = p.parse_args(argv)
    from relight.commands.common import _parse_size, parse_settings

    try:
        if a.spp is not None and a.spp < 1:
            raise RelightError("--spp must be at least 1", where="--spp")
        if Path(a.out).exists() and not Path(a.out).is_dir():
            raise RelightError("--out must be a folder", where=a.out)
        if any(len(v) < 2 for v in a.variant):
            raise RelightError("expected CASE KEY=VALUE [KEY=VALUE ...]", where="--variant")
        changes = {"out": Path(a.out), "progress": not a.quiet,
                   "estimators": tuple(_estimator(item) for item in a.estimator),
                   "students": tuple(_student(item) for item in a.student),
                   "variants": tuple((label, tuple(parse_settings(kv, "--variant").items()))
                                     for label, *kv in a.variant),
                   "cache": Path(a.cache) if a.cache else None}
        # an unknown case or a repeated label: before any work
        cases(changes["estimators"], changes["variants"], changes["students"])
        if a.size:
            changes["size"] = _parse_size(a.size)
        if a.spp:
            changes["spp"] = a.spp
        opts = Options.quick(**changes) if a.quick else Options(**changes)
        cmd = " ".join(["python -m relight.bench.real_assets", *(argv or sys.argv[1:])])
        report = run(opts, command=cmd)
    except RelightError as exc:
        print(f"{p.prog}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    print(markdown(report))
    return 0


def _estimator(item: str) -> tuple[str, str]:
    """``--estimator NAME=FILE`` -> (NAME, FILE), the file read as the viewer reads it."""
    from viewer.neural.shadow_net import read_shadow_net

    name, sep, path = item.partition("=")
    if not sep or not name or not path:
        raise RelightError(f"{item!r}: expected NAME=FILE", where="--estimator")
    read_shadow_net(path)  # a WeightsError names the file
    return name, path


def _student(item: str) -> tuple[str, str]:
    """``--student NAME=FILE`` -> (NAME, FILE), the file read as the viewer reads it."""
    from viewer.neural import load_network

    name, sep, path = item.partition("=")
    if not sep or not name or not path:
        raise RelightError(f"{item!r}: expected NAME=FILE", where="--student")
    load_network(path, "student")  # a WeightsError names the file
    return name, path


if __name__ == "__main__":
    raise SystemExit(main())
