"""Monte-Carlo convergence benchmark: error against a converged reference versus samples per pixel
for each sampling strategy (the thesis's uniform-vs-importance comparison, appendix B.4, measured),
and the frame time per sample.

    from relight.bench.mc import mc_convergence
    rows = mc_convergence(Renderer(), scene, ("uniform", "cosine", "env", "brdf", "mis"),
                          (1, 4, 16, 64), reference_spp=4096)

RMSE is on linear radiance over covered pixels; PSNR on the display image of the scene's settings
(exposure, tone mapping, sRGB), like :mod:`relight.bench.metrics`. The reference is a ``mis``
render with its own seed, so no strategy is compared with its own samples.
"""
from __future__ import annotations

import time

import numpy as np

from .metrics import psnr, rmse

REFERENCE_SEED = 987654321


def mc_convergence(renderer, scene, strategies=("uniform", "cosine", "env", "brdf", "mis"),
                   spp_list=(1, 4, 16, 64, 256), reference_spp: int = 4096) -> list[dict]:
    """One row per (strategy, samples): ``{"model": "ggx_mc", "variant": strategy, "samples",
    "size": "WxH", "ms": frame time of the whole render, "ms_per_sample", "rmse", "psnr"}``,
    plus the reference row (variant ``"reference"``). ``scene`` is rendered with ``ggx_mc``."""
    base = scene.with_render(model="ggx_mc")
    ref_scene = base.with_render(sampling="mis", samples=int(reference_spp), seed=REFERENCE_SEED)
    t0 = time.perf_counter()
    ref = renderer.render(ref_scene)
    ref_ms = (time.perf_counter() - t0) * 1e3
    covered = ref.radiance[..., 3] > 0
    w, h = ref.camera.size
    size = f"{w}x{h}"
    rows = [{"model": "ggx_mc", "variant": "reference", "samples": int(reference_spp),
             "size": size, "ms": ref_ms, "ms_per_sample": ref_ms / reference_spp,
             "rmse": 0.0, "psnr": float("inf")}]
    ref_display = ref.display[..., :3].astype(np.float64) / 255.0
    for strategy in strategies:
        for spp in spp_list:
            s = base.with_render(sampling=strategy, samples=int(spp))
            renderer.render(s)  # warm-up: programs and textures exist before timing
            with renderer.every_pass():  # a whole frame (G-buffer included)
                t0 = time.perf_counter()
                frame = renderer.render(s)
                ms = (time.perf_counter() - t0) * 1e3
            rows.append({
                "model": "ggx_mc", "variant": strategy, "samples": int(spp), "size": size,
                "ms": ms, "ms_per_sample": ms / spp,
                "rmse": rmse(ref.radiance[..., :3][covered], frame.radiance[..., :3][covered]),
                "psnr": psnr(ref_display, frame.display[..., :3].astype(np.float64) / 255.0),
            })
    return rows


if __name__ == "__main__":  # python -m relight.bench.mc [scene.toml]: a quick table
    import sys

    from viewer.renderer import Renderer
    from viewer.scene.description import load_scene

    from .scenes import bench_scene

    sc = load_scene(sys.argv[1]) if len(sys.argv) > 1 else bench_scene("mc_sphere")
    for row in mc_convergence(Renderer(), sc, spp_list=(1, 4, 16, 64), reference_spp=2048):
        print(f"{row['variant']:>9} {row['samples']:>5} spp  {row['ms']:8.1f} ms  "
              f"{row['ms_per_sample']:7.2f} ms/spp  rmse {row['rmse']:.4f}  "
              f"psnr {row['psnr']:.2f} dB")
