"""Parity results and how two arrays are compared: element-wise within atol + rtol, or within a
per-element error envelope."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from viewer.gl.context import texture_filter_bits


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


def compare_envelope(name: str, glsl: np.ndarray, ref: np.ndarray, bound: np.ndarray,
                     kind: str = "pass", measured: str = "", envelope: str = "") -> ParityResult:
    """Element-wise |glsl - ref| <= bound, with ``bound`` an error envelope per element derived
    from what the computation may legitimately do differently (for example
    :func:`learned.twins.ibl.sample_trilinear_envelope`); reports the largest share of it used."""
    glsl = np.asarray(glsl, dtype=np.float64)
    ref = np.asarray(ref, dtype=np.float64)
    if glsl.shape != ref.shape:
        return ParityResult(name, float("inf"), float("inf"), f"shape {glsl.shape} vs {ref.shape}",
                            False, kind, measured, envelope)
    bound = np.broadcast_to(np.asarray(bound, dtype=np.float64), ref.shape)
    diff = np.abs(glsl - ref)
    ok = bool(np.all(np.isfinite(glsl)) and np.all(np.isfinite(ref)) and np.all(diff <= bound))
    used = float(np.max(diff / np.maximum(bound, 1e-30))) if diff.size else 0.0
    # relative error where it means something: values above their own bound (as compare())
    big = np.abs(ref) > bound
    rel = diff[big] / np.abs(ref[big])
    return ParityResult(name, float(diff.max()) if diff.size else 0.0,
                        float(rel.max()) if rel.size else 0.0,
                        f"per-element envelope ({used:.2%} of it used)", ok, kind, measured,
                        envelope)


def device_filter_bits(programs) -> int:
    """Fraction bits of the device's texture filter (bilinear weights and lod fraction, the
    smaller), measured once per context by :func:`viewer.gl.context.texture_filter_bits`: 16 (the
    probe's resolution) on llvmpipe, 8 on GPUs. The envelopes of filtered lookups use it."""
    bits = getattr(programs, "filter_bits", None)
    if bits is None:
        bits = programs.filter_bits = min(texture_filter_bits(programs.ctx).values())
    return bits
