"""Every GLSL library function against its torch twin on the same inputs: the cases of
:mod:`learned.parity.cases`, evaluated in GL by :func:`viewer.gl.kernels.evaluate`."""
from __future__ import annotations

import itertools

import numpy as np
import torch

from learned.twins import find_twin
from viewer.gl.kernels import all_library_function_names, evaluate, library_functions

from .cases import all_cases, pass_level
from .cases.base import ParityCase
from .results import ParityResult, compare


def library_cases() -> dict[str, ParityCase]:
    """Every function case, by GLSL function name."""
    return {case.name: case for case in all_cases()}


def _inputs(case: ParityCase, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    drawn = [arg.draw(rng, case.n) for arg in case.args]
    # adversarial grid: every combination of each argument's adversarial values
    adv = [[np.broadcast_to(np.asarray(a, np.float32), (arg.components,)) for a in arg.adversarial]
           or [d[0] if d.ndim == 1 else d[0] for d in [arg.draw(rng, 1)]]
           for arg in case.args]
    combos = list(itertools.product(*adv))
    if combos and any(arg.adversarial for arg in case.args):
        grid = [np.array([np.asarray(c[i], np.float32).reshape(-1) for c in combos])
                for i in range(len(case.args))]
        grid = [g[:, 0] if arg.components == 1 else g for g, arg in zip(grid, case.args)]
        n_rand = case.n
        drawn = [np.concatenate([d[:n_rand], g], axis=0) for d, g in zip(drawn, grid)]
    if case.prepare is not None:
        drawn = case.prepare(drawn)
    return drawn


def check_function(programs, case: ParityCase, seed: int = 0) -> ParityResult:
    twin = find_twin(case.name)
    if twin is None:
        return ParityResult(case.name, float("inf"), float("inf"), "no torch twin", False)
    args = _inputs(case, seed)
    glsl = evaluate(programs, case.name, *args)
    with torch.no_grad():
        ref = twin(*[torch.from_numpy(np.ascontiguousarray(a)) for a in args])
    ref = np.asarray(ref.detach().cpu().numpy() if torch.is_tensor(ref) else ref, np.float32)
    if ref.ndim == 0:
        ref = ref.reshape(glsl.shape)
    if case.period is not None:  # the twin's phase moved to within half a period of the GLSL's
        p = float(case.period)
        ref = (glsl + (np.remainder(ref.astype(np.float64) - glsl + 0.5 * p, p) - 0.5 * p)
               ).astype(np.float32)
    return compare(case.name, glsl, ref, case.atol, case.rtol, measured=case.measured,
                   envelope=case.envelope)


def coverage() -> list[str]:
    """GLSL library functions without a parity case (scalar/vector ones) or without any twin."""
    problems = []
    cases = library_cases()
    testable = library_functions()
    covered_by_passes = pass_level()
    for name, file in all_library_function_names().items():
        if find_twin(name) is None:
            problems.append(f"{file}: {name} has no torch twin")
        elif name in testable and name not in cases:
            problems.append(f"{file}: {name} has no parity case")
        elif name not in testable and name not in covered_by_passes:
            problems.append(f"{file}: {name} takes samplers/structs but no pass check covers it")
    return problems
