"""``relight bench``'s shadow suites against path-traced truth.

``shadow_truth``: on each scene of :data:`SHADOW_SCENES` (``assets/scenes/shadows``, then
``assets/scenes/reference``; references stored in ``assets/references``: objects on a floor under
real HDRIs whose sun the renderer extracts and shadows, and in the procedural studio with and
without a directional key light),
every classical case of :data:`CANDIDATES` is rendered at the reference's size with the scene's
shadows on and with ``[render] shadows = false``, and scored against the reference
(:func:`relight.reference.compare.score`: PSNR, median relative error, energy bias, over covered
pixels). A row per scene gives the case that scores best *with* shadows, beside the same case
without: ``gain_db`` is what the shadow maps buy against truth, and ``gain_vs_best_without_db``
the same render against the best of every case without shadow maps (the strongest baseline that
has none). ``casters`` says what casts a shadow map there (the environment's sun, directional
lights, the environment's shadow directions where the case has ``env_shadows``); where nothing
does, the two renders are the same image and the gain is 0 by construction. The row's case is
chosen on these references themselves (no held-out split: the table says what each case
scores, not a tuned model's generalisation). ``psnr_map<n>`` scores the same case with
shadow maps of ``n`` texels a side instead of the default (:data:`MAP_SIZES`): the accuracy side of
the map size's speed/accuracy trade, whose cost the ``shadows`` suite measures;
``psnr_whole_casters`` the same case with whole meshes drawn into its maps
(``shadow_lod_error = 0``: no levels of detail).

``penumbra``: the 10-90 % width of a directional light's penumbra (2 and 8 deg) in the PCSS shadow
and in the path tracer (:mod:`relight.bench.penumbra`), traced live at 128^2, 256 spp (left out,
with a warning, where Mitsuba is not installed).
"""
from __future__ import annotations

import math
import warnings

from assets import ASSET_ROOT
from viewer.environment.maps import load_environment
from viewer.environment.sun import extract_sun
from viewer.errors import RelightError

from .truth import REFERENCE_SCENES, REFERENCES, TruthScene

SHADOW_SCENE_DIR = ASSET_ROOT / "scenes" / "shadows"  # apart from the fidelity scenes' folder
HELDOUT_SCENE_DIR = ASSET_ROOT / "scenes" / "heldout"  # scored only, never tuned on (bench rays)
VALIDATION_SCENE_DIR = ASSET_ROOT / "scenes" / "validation"  # where bench rays' designs are chosen

SHADOW_SCENES = ("sky_shadow_spheres", "esplanade_shadow_spheres", "park_sphere_on_plane",
                 "studio_key_spheres", "studio_sphere_on_plane")
ENV_SHADOW_DIRECTIONS = 8  # [render] env_shadows of the cases that use them
# the classical models and the rasteriser's visibility knobs (model, variant, changes): screen
# space (ssao, indirect) and the environment's shadows (shadows = false turns those off too)
CANDIDATES = (("ggx_split_sum", "default", {}),
              ("ggx_split_sum", "+ssao", {"ssao": True}),
              ("ggx_split_sum", "+ssao +indirect", {"ssao": True, "indirect": True}),
              ("ggx_split_sum", "+env shadows", {"env_shadows": ENV_SHADOW_DIRECTIONS}),
              ("ggx_split_sum", "+env shadows +ssao +indirect",
               {"env_shadows": ENV_SHADOW_DIRECTIONS, "ssao": True, "indirect": True}),
              ("ggx_split_sum", "+rays", {"raytrace": True}),
              ("ggx_split_sum", "+rays x4", {"raytrace": True, "raytrace_rays": 4}),
              ("blinn_phong", "default", {}),
              ("blinn_phong", "+rays", {"raytrace": True}),
              ("path", "64spp", {"samples": 64}))
MAP_SIZES = (512, 1024, 4096)  # besides the default 2048


def _casters(scene, changes=None) -> str:
    parts = []
    try:
        with warnings.catch_warnings():  # the renderer has said what loading it says
            warnings.simplefilter("ignore")
            _, sun = extract_sun(load_environment(scene.environment))
    except RelightError:
        sun = None
    if sun is not None and scene.render.sun:
        parts.append(f"sun ({math.degrees(2 * sun.angular_radius):.1f} deg, "
                     f"{100 * sun.share:.0f} % of the sky)")
    n = sum(1 for li in scene.lights if li.type == "directional" and li.shadow)
    if n:
        parts.append(f"{n} directional light{'s' if n > 1 else ''}")
    k = (changes or {}).get("env_shadows", 0)
    if k:
        parts.append(f"the environment ({k} directions)")
    return ", ".join(parts) or "nothing"


def truth_scene(name: str, suite: str) -> TruthScene | None:
    """The scene ``name`` (the shadow scenes' folder, the held-out scenes', the validation
    scenes', else the fidelity scenes') with its stored reference, or None with a warning naming
    ``suite`` when either is missing."""
    path = next((p for p in (d / f"{name}.toml" for d in (SHADOW_SCENE_DIR, HELDOUT_SCENE_DIR,
                                                           VALIDATION_SCENE_DIR))
                 if p.is_file()), REFERENCE_SCENES / f"{name}.toml")
    ts = TruthScene(name, path, REFERENCES / f"{name}.exr")
    if not ts.path.is_file() or not ts.reference.is_file():
        warnings.warn(f"relight bench {suite}: no scene or reference for {name}; left out",
                      stacklevel=3)
        return None
    return ts


def shadow_truth_rows(renderer, names=SHADOW_SCENES, candidates=CANDIDATES,
                      map_sizes=MAP_SIZES) -> list[dict]:
    """One row per scene of ``names`` with a stored reference (module docstring)."""
    from relight.reference import read_reference
    from relight.reference.compare import score

    rows = []
    for name in names:
        ts = truth_scene(name, "shadow_truth")
        if ts is None:
            continue
        truth = read_reference(ts.reference)
        h, w = truth.radiance.shape[:2]
        scene = ts.scene
        best = None
        best_without = -math.inf  # the strongest case without any shadow map
        for model, variant, changes in candidates:
            scores = {}
            for shadows in (True, False):
                image = renderer.render(scene.with_render(model=model, shadows=shadows, **changes),
                                        size=(w, h)).radiance
                scores[shadows] = score(image, truth)
            best_without = max(best_without, scores[False].psnr)
            if best is None or scores[True].psnr > best[2][True].psnr:
                best = (model, variant, scores)
        model, variant, s = best
        changes = dict(next(c for m, v, c in candidates if (m, v) == (model, variant)))
        by_size = {f"psnr_map{n}": score(renderer.render(scene.with_render(
            model=model, shadows=True, shadow_size=n, **changes), size=(w, h)).radiance,
            truth).psnr for n in map_sizes}
        # the same case with whole meshes in its maps (no levels of detail)
        by_size["psnr_whole_casters"] = score(renderer.render(scene.with_render(
            model=model, shadows=True, shadow_lod_error=0.0, **changes), size=(w, h)).radiance,
            truth).psnr
        rows.append({"scene": name, "casters": _casters(scene, changes), "size": f"{w}x{h}",
                     "spp": truth.meta.get("spp"), "model": model, "variant": variant,
                     "psnr_shadows": s[True].psnr, "psnr_without": s[False].psnr,
                     "gain_db": s[True].psnr - s[False].psnr,
                     "gain_vs_best_without_db": s[True].psnr - best_without, **by_size,
                     "median_rel_shadows_%": 100 * s[True].median_rel,
                     "median_rel_without_%": 100 * s[False].median_rel,
                     "bias_shadows_%": 100 * s[True].bias, "bias_without_%": 100 * s[False].bias})
    return rows


def penumbra_rows(renderer, diameters=(2.0, 8.0), size: int = 128, spp: int = 256) -> list[dict]:
    """Penumbra widths in pixels: the closed form of a uniform disc, the path tracer (with one
    standard error) and the PCSS shadow (:mod:`relight.bench.penumbra`)."""
    from .penumbra import (
                           expected_width_px,
                           penumbra_scene,
                           profile_stderr,
                           transition_width,
                           transition_width_noise,
                           visibility_profile,
    )

    try:
        from relight.reference import ReferenceOptions, render_reference

        rows = []
        for d in diameters:
            scene = penumbra_scene(d, size=size)
            ref = render_reference(scene, ReferenceOptions(spp=spp, max_depth=2), progress=False)
            profile = visibility_profile(ref.radiance)
            w_ref = transition_width(profile)
            w_ours = transition_width(visibility_profile(renderer.render(scene).radiance))
            rows.append({"diameter_deg": d, "size": f"{size}x{size}", "spp": spp,
                         "closed_form_px": expected_width_px(d, size), "reference_px": w_ref,
                         "reference_stderr_px": transition_width_noise(
                             profile, profile_stderr(ref.stderr)),
                         "pcss_px": w_ours, "pcss_minus_reference_px": w_ours - w_ref,
                         "pcss_rel_%": 100 * (w_ours / w_ref - 1.0)})
        return rows
    except RelightError as exc:  # no Mitsuba (or no LLVM): the suite is left out
        warnings.warn(f"relight bench penumbra: left out ({exc})", stacklevel=2)
        return []
