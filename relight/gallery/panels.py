"""The gallery's two panels: the glTF asset under each HDRI against its path-traced truth (cached
under ``--cache``; :func:`asset_panel`) and the fidelity spheres against their stored references
(:func:`sphere_panel`)."""
from __future__ import annotations

from pathlib import Path

from .cases import CASES, ENVIRONMENTS, ERROR_MAX, SPHERE_SCENES, Case, GalleryOptions
from .images import _save_png, compose, display, error_image

# ---- the asset under real light -----------------------------------------------------------------

def gallery_scene(environment: tuple[str, str, float], size: tuple[int, int] | None = None):
    """The gallery scene (``assets/scenes/gallery.toml``) under one entry of
    :data:`ENVIRONMENTS`."""
    from assets import ASSET_ROOT
    from viewer import load_scene

    scene = load_scene(ASSET_ROOT / "scenes" / "gallery.toml")
    _, file, rotation = environment
    scene = scene.with_environment(path=str(ASSET_ROOT / "environments" / file),
                                   rotation_deg=rotation)
    return scene.with_camera(size=size) if size is not None else scene


def cached_truth(scene, name: str, options: GalleryOptions, spp: int):
    """The path-traced reference of ``scene`` (``options.cache / <name>.exr``, with its
    ``.stderr.exr`` and ``.json``), from the cache when it holds this scene's configuration
    (:func:`relight.reference.render.config_key`: camera, environment, objects, render settings,
    reference options) with at least ``spp`` samples; else traced and written over that one file.
    Also :mod:`relight.bench.real_assets`' truth."""
    from ..reference import ReferenceOptions, read_reference, render_reference, write_reference
    from ..reference.keys import finished_reference

    ref_options = ReferenceOptions(spp=spp)
    out = options.cache / f"{name}.exr"
    if finished_reference(out, scene, ref_options, spp) is not None:
        return read_reference(out)
    options.cache.mkdir(parents=True, exist_ok=True)
    ref = render_reference(scene, ref_options, checkpoint=out.with_name(out.name + ".partial.npz"),
                           progress=options.progress)
    write_reference(ref, out)
    return ref


def _row(label: str, case: Case, s, extra: dict | None = None) -> dict:
    row = {"scene": label, "case": case.label, "bias_%": round(100 * s.bias, 2),
           "median_rel_%": round(100 * s.median_rel, 2), "psnr_db": round(s.psnr, 2),
           "pixels": s.pixels}
    row.update(extra or {})
    return row


def asset_panel(renderer, options: GalleryOptions, log) -> tuple[list[dict], list[Path], dict]:
    """Render the gallery scene under every environment with every case and path-trace it;
    writes ``hero.png`` and ``<environment>.png``; returns the score rows, the files and the
    truth's metadata per environment."""
    from ..reference.compare import coverage_mask, score

    envs = ENVIRONMENTS[:1] if options.quick else ENVIRONMENTS
    spp = 64 if options.quick else options.spp
    rows, files, truths = [], [], {}
    hero_grid, hero_rows = [], []
    hero_cases = [c for c in CASES if c.hero]
    for env in envs:
        name = env[0]
        scene = gallery_scene(env, options.size)
        log(f"{name}: path tracing ({spp} spp)")
        truth = cached_truth(scene, name, options, spp)
        truths[name] = {k: truth.meta.get(k) for k in ("spp", "max_depth", "variant", "mitsuba",
                                                        "seconds", "size")}
        images, errors = {}, {}
        for case in CASES:
            log(f"{name}: {case.label}")
            radiance = renderer.render(scene.with_render(**case.render)).radiance
            mask = coverage_mask(radiance, truth)
            rows.append(_row(name, case, score(radiance, truth, mask)))
            images[case.label] = display(radiance)
            errors[case.label] = error_image(radiance, truth, mask)
        truth_img = display(truth.radiance)
        labels = [c.label for c in CASES] + ["path-traced truth"]
        grid = [[images[c.label] for c in CASES] + [truth_img],
                [errors[c.label] for c in CASES] + [None]]
        img = compose(grid, labels, ["image", "error"],
                      note=f"{name}.exr; error: relative, beyond 2 standard errors of the "
                           f"truth, black 0 to yellow {ERROR_MAX:.0%} (grey: sky); truth: "
                           f"Mitsuba 3, {truth.meta['spp']} spp")
        files.append(_save_png(img, options.out / f"{name}.png"))
        hero_grid.append([images[c.label] for c in hero_cases] + [truth_img])
        hero_rows.append(name)
    hero = compose(hero_grid, [c.label for c in hero_cases] + ["path-traced truth"], hero_rows)
    files.insert(0, _save_png(hero, options.out / "hero.png"))
    return rows, files, truths


# ---- the fidelity spheres -----------------------------------------------------------------------

def sphere_panel(renderer, options: GalleryOptions, log) -> tuple[list[dict], list[Path]]:
    """Every case on every scene of ``assets/scenes/reference`` that has a stored reference,
    scored against it; ``spheres.png`` shows :data:`SPHERE_SCENES` (image above error)."""
    from assets import ASSET_ROOT
    from viewer import load_scene

    from ..reference import read_reference
    from ..reference.compare import coverage_mask, score

    rows, grid, labels = [], [], []
    for path in sorted((ASSET_ROOT / "scenes" / "reference").glob("*.toml")):
        ref_path = ASSET_ROOT / "references" / f"{path.stem}.exr"
        if not ref_path.is_file():
            continue
        truth = read_reference(ref_path)
        scene = load_scene(path)
        log(f"spheres: {path.stem}")
        images, errors = [], []
        for case in CASES:
            radiance = renderer.render(scene.with_render(**case.render)).radiance
            mask = coverage_mask(radiance, truth)
            rows.append(_row(path.stem, case, score(radiance, truth, mask),
                             {"truth_spp": truth.meta.get("spp")}))
            images.append(display(radiance))
            errors.append(error_image(radiance, truth, mask))
        if path.stem in SPHERE_SCENES:
            grid += [images + [display(truth.radiance)], errors + [None]]
            labels += [path.stem, ""]
    if not grid:
        return rows, []
    img = compose(grid, [c.label.replace(" + ", "\n+ ") for c in CASES] + ["truth"], labels,
                  scale=2, font_size=11,
                  note=f"under each row of images its error: black 0 to yellow {ERROR_MAX:.0%}")
    return rows, [_save_png(img, options.out / "spheres.png")]
