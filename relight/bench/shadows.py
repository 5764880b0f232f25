"""``relight bench``'s shadow suite: what shadow maps cost per frame.

The bench's mesh scene at 512^2 with 1 and 4 shadowing directional lights, ``shadow_size`` 2048
(the default) and 1024, each frame timed with shadows on and off in the same run (whole frames:
nothing reused; the two in alternating blocks, :func:`~relight.bench.timing.time_pair`), so a
row's ``ratio`` is the cost of the shadow passes and lookups relative to the same frame without
them: a frame in which a light or the geometry moved. Under the default shadow budget of one map
(:func:`viewer.graph.shadows.budgeted`) four lights' maps have half the set side (``map_size``);
a row per light count beyond the budget times them without it (``budget`` 0: every map at
``shadow_size``), the accuracy the budget trades. ``ratio_maps_kept``
is the same shadowed frame without its shadow passes (their fenced times taken out of the same
frames): what a camera move or a material or light-colour slider costs, since the frame graph keeps
a map whose light and casters did not change (a cascaded map follows the camera and is redrawn).
Absolute milliseconds on a shared CPU are noise; the ratios measured in one run are the numbers to
quote. What the map size costs in accuracy is the ``shadow_truth`` suite's ``psnr_map<n>``
(:mod:`relight.bench.shadow_truth`). The ``env_shadows`` rows time the environment's shadows
(:mod:`viewer.environment.sampling` ``median_cut`` directions, one atlas of maps) the same way."""
from __future__ import annotations

import dataclasses
import math

from viewer.graph.shadows import budgeted, env_shadow_tile
from viewer.lighting.lights import Light

from .timing import time_pair

SIZE = (512, 512)
MAP_SIZES = (2048, 1024)


def _lights(n: int) -> tuple[Light, ...]:
    """``n`` directional lights spread around the sky, 45 degrees up."""
    out = []
    for i in range(n):
        a = 2.0 * math.pi * i / max(n, 1)
        out.append(Light(direction=(math.cos(a) * 0.7071, 0.7071, math.sin(a) * 0.7071),
                         intensity=2.0 / max(n, 1)))
    return tuple(out)


def shadow_rows(renderer, scene, config, counts=(1, 4), size=SIZE,
                map_sizes=MAP_SIZES, env_counts=(8,)) -> list[dict]:
    """One row per light count and ``shadow_size`` under the default budget: ms per frame with
    and without shadow maps, their ratio, the ratio with the maps kept (module doc), the shadow
    passes' own share, how many were drawn per frame and the mesh triangles they drew
    (``map_triangles``: the casters' levels of detail), the side each map got (``map_size``);
    one per light count beyond the budget without it (``budget`` 0); one per light count with
    whole meshes in the maps (``lod_error`` 0); then one per count of ``env_counts``: the
    environment's shadows (``env_shadows``) without lights, against the same frame without them
    (``shadow_size``: their atlas's tile)."""
    rows = []
    default_error = scene.render.shadow.lod_error
    budget = scene.render.shadow.budget
    # each light count at each map size, then without the budget where it shrank the maps, then
    # at the default size with the whole meshes drawn into the maps (shadow_lod_error = 0): what
    # the casters' levels of detail save
    cases = [(n, m, budget, default_error) for n in counts for m in map_sizes]
    cases += [(n, map_sizes[0], 0.0, default_error) for n in counts if 0.0 < budget < n]
    cases += [(n, map_sizes[0], budget, 0.0) for n in counts] if default_error > 0.0 else []
    for n, map_size, b, error in cases:
        lit = dataclasses.replace(scene, lights=_lights(n)).with_camera(size=size)
        shadowed = lit.with_render(shadows=True, shadow_size=map_size, shadow_budget=b,
                                   shadow_lod_error=error)
        rows.append(_row(renderer, shadowed, lit.with_render(shadows=False), size, config,
                         kind="shadows", lights=n, shadow_size=map_size, env_shadows=0,
                         map_size=budgeted(shadowed.render.shadow, n).size))
    for k in env_counts:  # the environment's shadows alone (no light), default maps
        dark = dataclasses.replace(scene, lights=()).with_camera(size=size)
        tile = env_shadow_tile(scene.render.shadow.size)
        rows.append(_row(renderer, dark.with_render(env_shadows=k), dark, size, config,
                         kind="env_shadows", lights=0, shadow_size=tile, env_shadows=k,
                         map_size=tile))
    return rows


def _row(renderer, shadowed, plain, size, config, *, kind, lights, shadow_size,
         env_shadows, map_size) -> dict:
    """The timings of ``shadowed`` beside ``plain`` (the same scene without its shadow maps)."""
    (on_ms, on_pass), (off_ms, _) = time_pair(renderer, shadowed, plain, size, config)
    spass = renderer.resources.shadow_pass()
    spass.triangles = 0
    with renderer.every_pass():  # one more frame, to count what its maps drew
        renderer.draw(shadowed, size)
    passes = [p for p in on_pass if p.startswith("shadow")]
    shadow_ms = sum(on_pass[p] for p in passes)
    return {"kind": kind, "lights": lights, "size": f"{size[0]}x{size[1]}",
            "model": shadowed.render.model, "ms_shadows": on_ms, "ms_without": off_ms,
            "ratio": on_ms / max(off_ms, 1e-9),
            "ratio_maps_kept": (on_ms - shadow_ms) / max(off_ms, 1e-9),
            "shadow_pass_ms": shadow_ms, "shadow_passes": len(passes),
            "map_triangles": spass.triangles,  # mesh triangles drawn into its maps a frame
            "shadow_size": shadow_size, "budget": shadowed.render.shadow.budget,
            "map_size": map_size, "env_shadows": env_shadows,
            "lod_error": shadowed.render.shadow.lod_error}
