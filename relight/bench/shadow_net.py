"""``relight bench``'s shadow_net suite: what the neural shadow estimator costs beside SSAO.

The bench's mesh scene at 512^2 with SSAO (the estimator reads its occlusion) and ``[render]
shadow_net``: every timed frame runs both, so each frame gives the ratio of the estimator's fenced
time (its layers' passes and the product's, summed) to SSAO's occlusion pass (``ratio_ssao``, the issue's budget: at most 2),
and to SSAO with its blur (``ratio_ssao_blur``); the medians over the frames are reported, not
ratios of medians. For an estimator that reads S(x), the visibility of the environment's light,
SSAO in those frames also marches it (``SSAO_ENV_VIS``: 8 directions x 16 steps more per pixel;
the shipped mesh file does not read it); the frames without the estimator have SSAO without
it, so ``ratio_ssao_plain`` is the estimator against plain SSAO (the frames' medians, same run, alternating blocks). The whole frame with the estimator is also timed against the same frame
without it in alternating blocks (:func:`~relight.bench.timing.time_pair`: ``ratio_frame``).
The cost does not depend on the weights' values, only on the architecture: ``relight bench``
times the shipped mesh file, and seeded random weights of the default architecture without a
file (``weights`` says which). Absolute milliseconds on a
shared CPU are noise; the ratios measured in one run are the numbers to quote."""
from __future__ import annotations

import statistics
import tempfile
from pathlib import Path

from safetensors.numpy import save_file

from viewer.gl.timing import PassTimer
from viewer.neural.shadow_net import (
    DEFAULT_ARCHITECTURE,
    macs_per_pixel,
    metadata,
    random_tensors,
    read_shadow_net,
    receptive_field,
)

from .timing import time_pair

SIZE = (512, 512)


def _shown(path) -> str:
    """``path`` as the table shows it: relative to the repository for a shipped file."""
    from assets import ASSET_ROOT

    p = Path(path).resolve()
    root = ASSET_ROOT.resolve().parent
    return str(p.relative_to(root)) if p.is_relative_to(root) else str(path)


def _random_weights(folder: Path) -> Path:
    tensors = random_tensors(DEFAULT_ARCHITECTURE, seed=0)
    path = folder / "shadow_net_random.safetensors"
    save_file(tensors, str(path), metadata=metadata(DEFAULT_ARCHITECTURE, tensors,
                                                    {"bench": "random weights"}))
    return path


def _per_frame(renderer, scene, size, frames: int, warmup: int) -> list[dict]:
    """Each timed frame's fenced milliseconds per pass (whole frames: nothing reused)."""
    timer = renderer.profiler if isinstance(renderer.profiler, PassTimer) else \
        PassTimer(renderer.ctx)
    renderer.profiler = timer
    out = []
    with renderer.every_pass():
        for i in range(warmup + frames):
            timer.enabled = True
            timer.reset()
            renderer.draw(scene, size)
            if i >= warmup:
                out.append(dict(timer.milliseconds()))
    timer.enabled = False
    return out


def shadow_net_rows(renderer, scene, config, size=SIZE, weights: str | None = None
                    ) -> list[dict]:
    """One row: the estimator's and SSAO's milliseconds per frame (medians), their per-frame
    ratios' medians, and the whole frame with and without the estimator."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(weights) if weights else _random_weights(Path(tmp))
        net = read_shadow_net(path)
        base = scene.with_camera(size=size).with_render(ssao=True)
        with_net = base.with_render(shadow_net=str(path))
        frames = _per_frame(renderer, with_net, size, max(config.frames, 3), config.warmup)
        (on_ms, _), (off_ms, off_pass) = time_pair(renderer, with_net, base, size, config)

    for f in frames:  # the layers' passes (shadow_net:<layer>) and the product (shadow_net)
        f["estimator"] = sum(v for k, v in f.items()
                             if k == "shadow_net" or k.startswith("shadow_net:"))

    def med(key):
        return statistics.median(f.get(key, 0.0) for f in frames)

    ratios = [f["estimator"] / f["ssao"] for f in frames]
    blurred = [f["estimator"] / (f["ssao"] + f.get("ssao_blur", 0.0)) for f in frames]
    return [{"kind": "shadow_net", "size": f"{size[0]}x{size[1]}",
             "weights": _shown(weights) if weights else "random (default architecture)",
             "levels": net.architecture["levels"],
             "widths": ",".join(str(w) for w in net.architecture["widths"]),
             "receptive_field_px": receptive_field(net.architecture),
             "macs_per_pixel": round(macs_per_pixel(net.architecture), 1),
             "shadow_net_ms": med("estimator"), "ssao_ms": med("ssao"),
             "ssao_blur_ms": med("ssao_blur"),
             "ratio_ssao": statistics.median(ratios),
             "ratio_ssao_blur": statistics.median(blurred),
             "ssao_plain_ms": off_pass.get("ssao", float("nan")),
             "ratio_ssao_plain": med("estimator") / off_pass.get("ssao", float("nan")),
             "frame_ms": on_ms, "frame_without_ms": off_ms, "ratio_frame": on_ms / off_ms,
             "frames": len(frames)}]
