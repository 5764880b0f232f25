"""``relight bench``'s extra suites, each a section of ``bench.json`` and a table of ``bench.md``:
``SUITES`` maps a name to ``callable(renderer, scenes, config, cache) -> list[row dict]``."""
from __future__ import annotations

import warnings
from collections.abc import Callable

from viewer.errors import RelightError
from viewer.models import MODELS

from .clamps import clamp_costs
from .mc import mc_convergence


def _suite_mc(renderer, scenes, config, cache) -> list[dict]:
    """Error vs samples per pixel for every sampling strategy (thesis ch. 5: uniform vs importance
    sampling, measured), and time per sample, on the mesh scene."""

    if "ggx_mc" not in MODELS:
        return []
    scene = scenes["mesh"].with_camera(size=config.sizes[0])
    spps = (1, 4, 16, 64) if config.quick else (1, 4, 16, 64, 256)
    return mc_convergence(renderer, scene, spp_list=spps, reference_spp=config.reference_spp)


def _suite_splats(renderer, scenes, config, cache) -> list[dict]:
    """Splats per second including sorting (CPU and GPU sort) and GLSL vs the torch twin."""
    try:
        from .splats import glsl_vs_torch, splat_throughput
    except ImportError:
        return []
    counts = (10_000, 100_000) if config.quick else (10_000, 100_000, 1_000_000)
    rows = splat_throughput(renderer.programs, counts=counts, size=512,
                            frames=2 if config.quick else 3)
    try:
        rows += glsl_vs_torch(renderer.programs)
    except ImportError:  # no torch: the GLSL rows only
        pass
    return rows


def _suite_neural(renderer, scenes, config, cache) -> list[dict]:
    """Student vs teacher (128 samples): frame-time ratio and PSNR; GLSL vs torch MLP throughput."""

    if "neural" not in MODELS:
        return []
    from .neural import neural_rows

    return neural_rows(renderer, quick=config.quick)


def _suite_heldout(renderer, scenes, config, cache) -> list[dict]:
    """Every model against path-traced truth on the held-out datasets of ``config.heldout``
    (:mod:`relight.bench.heldout`), with each dataset's Pareto front marked."""
    if not config.heldout:
        return []
    from .heldout import heldout_rows

    return heldout_rows(renderer, config.heldout)


def _suite_clamps(renderer, scenes, config, cache) -> list[dict]:
    """What each shading clamp (roughness, n.v, ACES input, dfg.y) costs against an unclamped
    reference (:mod:`relight.bench.clamps`)."""

    return clamp_costs(renderer, config)


def _suite_environments(renderer, scenes, config, cache) -> list[dict]:
    """A new 2048x1024 EXR with a sun: first frame in a warm process, and the environment part in
    a new process with and without the disk cache, against the method before
    (:mod:`relight.bench.environments`)."""
    from .environments import suite

    return suite(renderer, scenes, config, cache)


def _suite_shadows(renderer, scenes, config, cache) -> list[dict]:
    """What shadow maps cost: whole frames at 512^2 with 1 and 4 shadowing lights, with and
    without shadows in the same run (:mod:`relight.bench.shadows`)."""
    from .shadows import shadow_rows

    return shadow_rows(renderer, scenes["mesh"].with_render(sun=False), config)


def _suite_antialias(renderer, scenes, config, cache) -> list[dict]:
    """What FXAA and 2x supersampling cost: whole frames at 512^2 against the same frame without
    anti-aliasing, in the same run (:mod:`relight.bench.antialias`)."""
    from .antialias import antialias_rows

    return antialias_rows(renderer, scenes["mesh"], config)


def _suite_memory(renderer, scenes, config, cache) -> list[dict]:
    """Resident memory under the sweeps that used to grow without bound: 150 frame widths, 20
    environments, 50 meshes, each in a fresh renderer (:mod:`relight.bench.memory`). Minutes
    long: left out of ``--quick``."""
    if config.quick:
        return []
    from viewer.renderer import Renderer

    from .memory import memory_rows

    return memory_rows(lambda: Renderer(ctx=renderer.ctx), scenes["mesh"], cache / "memory")


def _suite_shadow_truth(renderer, scenes, config, cache) -> list[dict]:
    """The best classical model with shadow maps and without, against path-traced references of
    objects on floors under a sun and studio lights (:mod:`relight.bench.shadow_truth`)."""
    from .shadow_truth import shadow_truth_rows

    return shadow_truth_rows(renderer)


def _suite_rays(renderer, scenes, config, cache) -> list[dict]:
    """The real-time tier's ray-traced visibility and bounce against SSAO + indirect light and
    the path tracer, against stored truth, and its frame time at 512^2 beside the baseline's
    (:mod:`relight.bench.rays`)."""
    from .rays import rays_rows

    return rays_rows(renderer, quick=config.quick)


def _suite_penumbra(renderer, scenes, config, cache) -> list[dict]:
    """PCSS penumbra widths against the path tracer's, 2 and 8 deg suns
    (:mod:`relight.bench.penumbra`); traced live, so needs Mitsuba."""
    from .shadow_truth import penumbra_rows

    return penumbra_rows(renderer)


def _suite_splat_decomp(renderer, scenes, config, cache) -> list[dict]:
    """The splat material/light decomposition relit under two unseen environments against
    path-traced truth, beside the floor (baked colours) and the ceiling (true materials)
    (:mod:`relight.bench.splat_decomp`); needs torch and Mitsuba. ``--quick``: one scene,
    fewer samples and iterations."""
    try:
        from relight.reference import load_mitsuba

        if load_mitsuba(None)[2].startswith("scalar"):
            raise RelightError("needs Mitsuba's LLVM variant (libLLVM >= 19)")
        from .splat_decomp import SplatDecompConfig, splat_decomp_rows
    except (ImportError, RelightError) as exc:
        warnings.warn(f"relight bench splat_decomp: left out ({exc})", stacklevel=2)
        return []
    cfg = SplatDecompConfig()
    if config.quick:
        cfg = SplatDecompConfig(scenes=cfg.scenes[:1], bake_spp=16, truth_spp=64, iterations=60)
    return splat_decomp_rows(renderer, cache, cfg)


def _suite_path(renderer, scenes, config, cache) -> list[dict]:
    """The path tracer against the stored references (block z-test, energy bias, PSNR, time per
    sample), its samples per second beside Mitsuba's on the same scenes, and BVH build time,
    bytes and rays per second at 10^4-10^6 triangles (:mod:`relight.bench.path`). ``--quick``:
    16 samples per seed, no 10^6-triangle BVH, 2^16 rays."""
    from .path import PathBenchConfig, path_rows

    return path_rows(renderer, PathBenchConfig.from_bench(config), progress=True)


def _suite_shadow_net(renderer, scenes, config, cache) -> list[dict]:
    """The neural shadow estimator's time at 512^2 beside SSAO's in the same frames, and the
    whole frame with and without it (:mod:`relight.bench.shadow_net`): the shipped mesh file
    (it reads no S(x), so the frame marches none), and seeded random weights of the default
    architecture (which read S(x)) when it is missing."""
    from assets import ASSET_ROOT

    from .shadow_net import shadow_net_rows

    shipped = ASSET_ROOT / "weights" / "shadow_net_mesh.safetensors"
    return shadow_net_rows(renderer, scenes["mesh"], config,
                           weights=str(shipped) if shipped.is_file() else None)


def _suite_real_assets(renderer, scenes, config, cache) -> list[dict]:
    """Issue 38's real-asset criterion: every bundled glTF on a floor under every bundled HDRI,
    the student and split-sum with the same visibility against path-traced truth, with a verdict
    per row (:mod:`relight.bench.real_assets`; ``--quick``: the gun under lobby and under sky
    with and without its sun). Traces its truth once
    (5.5 minutes for the whole run on two shared cores), then reads it from the cache."""
    from .real_assets import suite_rows

    return suite_rows(renderer, scenes, config, cache)


def _suite_shadow_trade(renderer, scenes, config, cache) -> list[dict]:
    """Every visibility option of the rasterised frame (SSAO, contact shadows, the blurred bounce,
    the shipped shadow estimators, the ray-traced tier at 1-8 frames) against path-traced truth
    on the val split of each ``--trade`` protocol dataset, meshes, stacks and splats, timed in
    the same run and read at equal time and equal accuracy (:mod:`relight.bench.shadow_trade`;
    needs torch). Without ``--trade`` it is left out, with a warning."""
    if not config.trade:
        warnings.warn("relight bench shadow_trade: left out (no protocol dataset: give --trade "
                      "DATA, e.g. from relight data DATA --protocol)", stacklevel=2)
        return []
    from .shadow_trade import suite_rows

    return suite_rows(renderer, config.trade, config, cache.parent / "shadow_trade")


# Extra suites, each a section of bench.json and a table of bench.md:
# name -> callable(renderer, scenes, config, cache) -> list[row dict]
SUITES: dict[str, Callable] = {"mc_convergence": _suite_mc, "splats": _suite_splats,
                               "neural": _suite_neural, "clamps": _suite_clamps,
                               "heldout": _suite_heldout, "environments": _suite_environments,
                               "shadows": _suite_shadows, "antialias": _suite_antialias,
                               "memory": _suite_memory, "shadow_truth": _suite_shadow_truth,
                               "penumbra": _suite_penumbra, "splat_decomp": _suite_splat_decomp,
                               "path": _suite_path, "rays": _suite_rays,
                               "shadow_net": _suite_shadow_net,
                               "real_assets": _suite_real_assets,
                               "shadow_trade": _suite_shadow_trade}

