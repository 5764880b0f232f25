"""``relight bench --suite rays``: what the real-time tier (``[render] raytrace``) buys and costs,
against the strongest real-time row before it (``ggx_split_sum`` with SSAO and its indirect
light, shadow maps on) and against the path tracer, on every scene with a stored path-traced
reference where something can occlude (the shadow scenes, the spheres on planes, a diffuse
sphere), and its frame time at 512² beside that baseline's in the same run. The neural student
is scored on both inputs it can have: the rays (``neural_rays``, the default render) and its
screen-space visibility S(x) (``neural_screen``).

Rows of two kinds:

* ``kind = truth``: one per scene, the PSNR of each rung against the reference
  (``relight.reference.compare.score``: covered pixels, peak the reference's 99.9th percentile)
  and the tier's gain over the baseline, with ``split``: ``tuned`` for the scenes the tier's
  knobs (filter steps, the diffuse rays' blur) were chosen on (read their gains as measured, not
  predicted), ``validation`` for :data:`VALIDATION` (where later designs were chosen, beside
  the tuned scenes) and ``heldout`` for :data:`HELDOUT` (``assets/scenes/heldout``: the spheres
  under the two HDRIs the tuned scenes lack, the gallery's textured glTF on a floor under every bundled
  HDRI), added after the knobs were fixed and scored once per shipped result; their references
  are antialiased (rays jittered over the pixel, 4096 spp), so every rung renders them with
  :data:`REFERENCE_SSAA` (the ``ssaa`` column). Each split has its mean row.
* ``kind = time``: the esplanade spheres at 512², the baseline's frame and the tier's in
  alternating blocks (:func:`relight.bench.timing.time_pair`): whole frames of the interactive
  viewer (``progressive``: one frame of rays, as a still view adds a frame) and of a headless
  render (its :data:`viewer.graph.raytrace.STILL_FRAMES` frames of rays at once).
"""
from __future__ import annotations

import statistics
import time

from .shadow_truth import SHADOW_SCENE_DIR, truth_scene

SCENES = ("esplanade_shadow_spheres", "sky_shadow_spheres", "studio_key_spheres",
          "park_sphere_on_plane", "studio_sphere_on_plane", "park_diffuse")
HELDOUT = ("lobby_shadow_spheres", "park_shadow_spheres", "esplanade_gun", "lobby_gun",
           "park_gun", "sky_gun", "studio_gun")
# assets/scenes/validation: the gun from its other side under every HDRI turned 120 degrees, other
# spheres under two; where the tier's later designs (the wide lobes' Monte Carlo specular) were
# chosen, so that the held-out split stays unseen
VALIDATION = ("esplanade_gun_val", "lobby_gun_val", "park_gun_val", "sky_gun_val",
              "studio_gun_val", "esplanade_spheres_val", "studio_spheres_val")
BASELINE = {"ssao": True, "indirect": True, "raytrace": False}
RUNGS = (("split_sum", {"raytrace": False}), ("ssao_indirect", BASELINE),
         ("rays", {"raytrace": True}),
         ("rays_x4", {"raytrace": True, "raytrace_rays": 4}),
         ("rays_undenoised", {"raytrace": True, "ray_denoise": False}),
         # the neural student (its default weights) under the rays and on its screen-space
         # visibility input S(x) (SSAO on, as its weights ask, rays off)
         ("neural_rays", {"model": "neural", "raytrace": True}),
         ("neural_screen", {"model": "neural", "raytrace": False}))
PATH_SPP = 64
# supersampling of the renders scored against an antialiased reference: 4 x 4 subpixels, each
# shaded at its centre with mip-mapped textures, box-averaged as the reference's jittered rays are
REFERENCE_SSAA = 4


def reference_is_antialiased(ref) -> bool:
    """Whether ``relight reference --antialias`` made ``ref`` (rays jittered over each pixel)."""
    return str(ref.meta.get("rays", "")).startswith("jittered")


def rays_rows(renderer, quick: bool = False) -> list[dict]:
    rows = []
    for split, names in (("tuned", SCENES), ("validation", VALIDATION), ("heldout", HELDOUT)):
        scored = [_truth_row(renderer, name, split, quick) for name in names]
        scored = [r for r in scored if r is not None]
        rows += scored
        if scored:
            rows.append({"kind": "truth", "split": split, "scene": "mean"} | {
                k: statistics.mean(r[k] for r in scored)
                for k in ("psnr_ssao_indirect", "psnr_rays", "gain_rays_db")})
    rows += rays_timing(renderer, quick)
    return rows


def _truth_row(renderer, name: str, split: str, quick: bool) -> dict | None:
    """One scene's PSNR per rung against its stored reference, or None (warned) without one."""
    from relight.reference import read_reference
    from relight.reference.compare import score

    ts = truth_scene(name, "rays")
    if ts is None:
        return None
    truth = read_reference(ts.reference)
    h, w = truth.radiance.shape[:2]
    # an antialiased reference (rays jittered over the pixel: the box-filtered image) is met by
    # supersampled renders; a pixel-centre one by the pixel-centre renders it was made for
    ssaa = REFERENCE_SSAA if reference_is_antialiased(truth) else 1
    row = {"kind": "truth", "split": split, "scene": name, "size": f"{w}x{h}", "ssaa": ssaa}
    for label, changes in RUNGS:
        image = renderer.render(ts.scene.with_render(ssaa=ssaa, **changes), size=(w, h)).radiance
        row[f"psnr_{label}"] = score(image, truth).psnr
    spp = 16 if quick else PATH_SPP
    # the path tracer's samples per pixel, over every subpixel together
    image = renderer.render(ts.scene.with_render(model="path", ssaa=ssaa,
                                                 samples=max(1, spp // (ssaa * ssaa))),
                            size=(w, h)).radiance
    row[f"psnr_path{spp}"] = score(image, truth).psnr
    row["gain_rays_db"] = row["psnr_rays"] - row["psnr_ssao_indirect"]
    return row


def rays_timing(renderer, quick: bool = False, size=(512, 512)) -> list[dict]:
    """Frame times of the baseline and the tier at ``size``, alternating (module docstring)."""
    from viewer.scene.description import load_scene

    scene = load_scene(SHADOW_SCENE_DIR / "esplanade_shadow_spheres.toml").with_camera(size=size)
    base = scene.with_render(**BASELINE)
    rays = scene.with_render(raytrace=True)
    rounds = 2 if quick else 3
    out = {"kind": "time", "scene": f"esplanade_shadow_spheres {size[0]}x{size[1]}"}
    for mode, progressive in (("viewer_frame", True), ("headless", False)):
        times = {"base": [], "rays": []}
        for s in (base, rays):  # warm: programs, BVH, environment
            renderer.draw(s, progressive=progressive)
        with renderer.every_pass():
            for _ in range(rounds):
                for key, s in (("base", base), ("rays", rays)):
                    if progressive:  # a still view's next frame: a fresh history each round
                        renderer.draw(s.with_render(seed=len(times[key]) + 1), progressive=True)
                    t0 = time.perf_counter()
                    renderer.draw(s, progressive=progressive)
                    renderer.ctx.finish()
                    times[key].append(1000.0 * (time.perf_counter() - t0))
        b, r = statistics.median(times["base"]), statistics.median(times["rays"])
        out[f"{mode}_base_ms"] = b
        out[f"{mode}_rays_ms"] = r
        out[f"{mode}_ratio"] = r / b
    return [out]
