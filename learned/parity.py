"""Torch-vs-GLSL parity: every GLSL library function, every precomputation and shading pass.

``relight parity`` and ``tests/shaders/test_parity.py`` both call :func:`run_parity`. Library
functions are compared element-wise through :func:`viewer.gl.kernels.evaluate`; passes (precompute,
shading models) register a check function in :data:`PASS_CHECKS` that renders with GL, runs the
torch twin on the same inputs and returns a :class:`ParityResult`.
"""
from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass
from typing import Callable

import numpy as np
import torch

from viewer.gl.kernels import all_library_function_names, evaluate, library_functions

from .twins import find_twin, twin_modules
from .twins._cases import ParityCase


@dataclass
class ParityResult:
    name: str
    max_abs: float
    max_rel: float
    tolerance: str
    passed: bool
    kind: str = "function"  # "function" | "pass" | "model"
    measured: str = ""
    envelope: str = ""

    def as_json(self) -> dict:
        d = asdict(self)
        return {k: d[k] for k in ("name", "max_abs", "max_rel", "tolerance", "passed", "kind",
                                  "envelope")}


# name -> (model or None, check(renderer_or_programs) -> list[ParityResult]).  Filled by modules
# that own passes (IBL precompute, shading models) through :func:`register_pass_check`.
PASS_CHECKS: dict[str, tuple[str | None, Callable]] = {}


def register_pass_check(name: str, model: str | None = None):
    """Decorator: ``check(programs) -> list[ParityResult]`` compared at pass level."""

    def deco(fn):
        PASS_CHECKS[name] = (model, fn)
        return fn

    return deco


def library_cases() -> dict[str, ParityCase]:
    cases: dict[str, ParityCase] = {}
    for mod in twin_modules():
        for case in getattr(mod, "PARITY_CASES", []):
            cases[case.name] = case
    return cases


def compare(name: str, glsl: np.ndarray, ref: np.ndarray, atol: float, rtol: float,
            kind: str = "function", measured: str = "", envelope: str = "") -> ParityResult:
    """Element-wise |glsl - ref| <= atol + rtol |ref|; non-finite values must match exactly."""
    glsl = np.asarray(glsl, dtype=np.float64)
    ref = np.asarray(ref, dtype=np.float64)
    if glsl.shape != ref.shape:
        return ParityResult(name, float("inf"), float("inf"), f"shape {glsl.shape} vs {ref.shape}",
                            False, kind, measured, envelope)
    finite = np.isfinite(ref) & np.isfinite(glsl)
    same_nonfinite = np.array_equal(np.isfinite(ref), np.isfinite(glsl))
    diff = np.abs(glsl - ref)[finite]
    rel = diff / np.maximum(np.abs(ref[finite]), 1e-30)
    max_abs = float(diff.max()) if diff.size else 0.0
    # relative error is reported where it is meaningful (|ref| above the absolute tolerance)
    big = np.abs(ref[finite]) > max(atol, 1e-12)
    max_rel = float(rel[big].max()) if big.any() else 0.0
    ok = bool(same_nonfinite and np.all(diff <= atol + rtol * np.abs(ref[finite])))
    return ParityResult(name, max_abs, max_rel, f"atol {atol:g} + rtol {rtol:g}", ok, kind, measured,
                        envelope)


_FILTER_BITS: dict[int, int] = {}


def device_filter_bits(programs) -> int:
    """Fraction bits of the device's texture filter (bilinear weights and lod fraction, the
    smaller), measured once per context by :func:`viewer.gl.context.texture_filter_bits`: 16 (the
    probe's resolution) on llvmpipe, 8 on GPUs. The envelopes of filtered lookups use it."""
    from viewer.gl.context import texture_filter_bits

    key = id(programs.ctx)
    if key not in _FILTER_BITS:
        _FILTER_BITS[key] = min(texture_filter_bits(programs.ctx).values())
    return _FILTER_BITS[key]


def compare_envelope(name: str, glsl: np.ndarray, ref: np.ndarray, bound: np.ndarray,
                     kind: str = "pass", measured: str = "", envelope: str = "") -> ParityResult:
    """Element-wise |glsl - ref| <= bound, with ``bound`` an error envelope per element derived
    from what the computation may legitimately do differently (for example
    :func:`learned.twins.ibl.sample_trilinear_envelope`); reports the largest share of it used."""
    glsl = np.asarray(glsl, dtype=np.float64)
    ref = np.asarray(ref, dtype=np.float64)
    bound = np.broadcast_to(np.asarray(bound, dtype=np.float64), ref.shape)
    if glsl.shape != ref.shape:
        return ParityResult(name, float("inf"), float("inf"), f"shape {glsl.shape} vs {ref.shape}",
                            False, kind, measured, envelope)
    diff = np.abs(glsl - ref)
    ok = bool(np.all(np.isfinite(glsl)) and np.all(np.isfinite(ref)) and np.all(diff <= bound))
    used = float(np.max(diff / np.maximum(bound, 1e-30))) if diff.size else 0.0
    rel = diff / np.maximum(np.abs(ref), 1e-30)
    return ParityResult(name, float(diff.max()) if diff.size else 0.0,
                        float(rel.max()) if rel.size else 0.0,
                        f"per-element envelope ({used:.2%} of it used)", ok, kind, measured,
                        envelope)


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
    return compare(case.name, glsl, ref, case.atol, case.rtol, measured=case.measured,
                   envelope=case.envelope)


def coverage() -> list[str]:
    """GLSL library functions without a parity case (scalar/vector ones) or without any twin."""
    problems = []
    cases = library_cases()
    testable = library_functions()
    pass_level = {n for mod in twin_modules() for n in getattr(mod, "PASS_LEVEL", ())}
    for name, file in all_library_function_names().items():
        if find_twin(name) is None:
            problems.append(f"{file}: {name} has no torch twin")
        elif name in testable and name not in cases:
            problems.append(f"{file}: {name} has no parity case")
        elif name not in testable and name not in pass_level:
            problems.append(f"{file}: {name} takes samplers/structs but no pass check covers it")
    return problems


def run_parity(programs, model: str | None = None, seed: int = 0) -> list[ParityResult]:
    """All library functions (unless ``model`` narrows to one model's passes) and pass checks."""
    results: list[ParityResult] = []
    twin_modules()  # importing the twin modules registers their pass checks
    if model is None:
        for case in library_cases().values():
            results.append(check_function(programs, case, seed))
    for name, (pass_model, check) in PASS_CHECKS.items():
        if model is None or pass_model in (model, None):
            results.extend(check(programs))
    return results
