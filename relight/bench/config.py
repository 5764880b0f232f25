"""What one ``relight bench`` run measures (:class:`BenchConfig`): its own module so that a
suite and the runner can both read it without importing each other."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BenchConfig:
    quick: bool = False
    frames: int = 10  # timed frames per case (after warm-up)
    warmup: int = 2
    reference_spp: int = 1024  # samples per pixel of the converged ggx_mc reference
    truth_spp: int = 4096  # samples per pixel of the converged ggx_mc on the reference scenes
    truth: bool = True  # measure against the path-traced references (relight.bench.truth)
    # held-out datasets with path-traced targets (relight.bench.heldout): every model's scores and
    # Pareto front on each
    heldout: tuple[str, ...] = ()
    # protocol datasets (relight data DATA --protocol) of the shadow_trade suite
    trade: tuple[str, ...] = ()

    @property
    def sizes(self) -> list[tuple[int, int]]:
        return [(160, 100)] if self.quick else [(256, 160), (512, 320)]
