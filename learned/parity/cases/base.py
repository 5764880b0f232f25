"""Input domains for parity cases (shared by every twin module)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class Arg:
    """How to draw one argument: uniform in [lo, hi] (per component), or unit vectors, plus
    adversarial values appended to the random ones."""

    kind: str = "uniform"  # "uniform" | "unit" (unit vectors) | "hemisphere" (unit, z >= 0) | "int"
    lo: float = 0.0
    hi: float = 1.0
    components: int = 1
    adversarial: tuple = ()  # extra values (scalars, or tuples for vectors)

    def draw(self, rng: np.random.Generator, n: int) -> np.ndarray:
        c = self.components
        if self.kind in ("unit", "hemisphere"):
            v = rng.normal(size=(n, c))
            v /= np.linalg.norm(v, axis=1, keepdims=True)
            if self.kind == "hemisphere":
                v[:, -1] = np.abs(v[:, -1])
        elif self.kind == "int":
            v = rng.integers(int(self.lo), int(self.hi) + 1, size=(n, c)).astype(np.float64)
        else:
            v = rng.uniform(self.lo, self.hi, size=(n, c))
        if self.adversarial:
            extra = np.array([np.broadcast_to(np.asarray(a, dtype=np.float64), (c,))
                              for a in self.adversarial])
            v = np.concatenate([v, extra], axis=0)
        v = v.astype(np.float32)
        return v[:, 0] if c == 1 else v


@dataclass(frozen=True)
class ParityCase:
    """One GLSL library function against its torch twin.

    ``atol``/``rtol``: an element passes if |glsl - torch| <= atol + rtol * |torch|. ``envelope``
    says where the bound comes from: the error float32 arithmetic may make on any conforming GL
    (operations x ulp, the GLSL 4.60 precision table: + - * correctly rounded, / 2.5 ulp, exp2
    3 + 2|x| ulp, log2 3 ulp or 2^-21 absolute in [0.5, 2], inversesqrt 2 ulp, sqrt as 1 /
    inversesqrt; trigonometric functions have no required precision: ~1e-6 absolute is assumed,
    what GPUs' and llvmpipe's implementations reach) and the conditioning of the function at the
    tested inputs. Write the error measured on llvmpipe in ``measured`` so a reader sees how much
    headroom the tolerance has.
    Adversarial values of all arguments are combined as a grid (every combination is evaluated).
    """

    name: str
    args: tuple[Arg, ...]
    atol: float = 1e-6
    rtol: float = 1e-5
    measured: str = ""
    envelope: str = ""
    n: int = 4096
    # a phase: compared modulo ``period`` (the shorter way round), so a fract that wraps on one
    # side and not the other (a rounding apart) is the same phase, not an error of one period
    period: float | None = None
    prepare: Callable | None = field(default=None, compare=False)  # optional fixup of drawn inputs
