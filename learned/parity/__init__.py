"""Torch-vs-GLSL parity: every GLSL library function, every precomputation and shading pass.

``relight parity`` and the tests call :func:`run_parity`. Library functions are compared
element-wise (:mod:`.functions`, cases in :mod:`.cases`); passes (precompute, shading models,
splats, SSAO, networks) by the checks of :mod:`.checks`, listed in :mod:`.registry`. Every
tolerance states the error envelope it guards (:class:`~.cases.base.ParityCase`); checks of
filtered texture lookups compare against a per-output envelope (:func:`.results.compare_envelope`).
The twins themselves (:mod:`learned.twins`) are pure torch mirrors of the GLSL and know nothing of GL.
"""
from __future__ import annotations

from .functions import check_function, coverage, library_cases
from .registry import check_models, pass_checks
from .results import ParityResult, compare, compare_envelope, device_filter_bits

__all__ = ["ParityResult", "check_function", "check_models", "compare", "compare_envelope",
           "coverage", "device_filter_bits", "library_cases", "pass_checks", "run_parity"]


def run_parity(programs, model: str | None = None, seed: int = 0,
               skip: tuple[str, ...] = ()) -> list[ParityResult]:
    """All library functions (unless ``model`` narrows to one model's passes) and pass checks
    (but those named in ``skip``)."""
    results: list[ParityResult] = []
    if model is None:
        for case in library_cases().values():
            results.append(check_function(programs, case, seed))
    for name, (pass_model, check) in pass_checks().items():
        if name not in skip and (model is None or pass_model in (model, None)):
            results.extend(check(programs))
    return results
