"""Parity cases of ``shaders/lib/contact.glsl`` against :mod:`learned.twins.contact`. The march
over the G-buffer (``contact_shadow`` of passes/lights.glsl) is checked by the contact-shadow
tests against analytic geometry (tests/viewer/test_contact_shadows.py)."""
from __future__ import annotations

import numpy as np

from .base import Arg, ParityCase

PASS_LEVEL = ()


def _camera_frames(args):
    """An orthonormal camera frame per row (right, up, back) and points in front of the camera
    (view depth 0.2..5.2, within 1.5 x the frustum's half-width), as contact shadows project."""
    p, right, up, back, cam, tan, res = (np.array(a, np.float64, copy=True) for a in args)
    up = up - (up * right).sum(1, keepdims=True) * right
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    back = np.cross(right, up)
    depth = 0.2 + np.abs(p[:, 2])
    xy = p[:, :2] / 5.0 * 1.5 * tan * depth[:, None]
    p = cam + xy[:, :1] * right + xy[:, 1:] * up - depth[:, None] * back
    return [a.astype(np.float32) for a in (p, right, up, back, cam, tan, res)]

PARITY_CASES = [
    ParityCase("contact_project", (Arg(lo=-5.0, hi=5.0, components=3),
                                   Arg(kind="unit", components=3),
                                   Arg(kind="unit", components=3),
                                   Arg(kind="unit", components=3),
                                   Arg(lo=-1.0, hi=1.0, components=3),
                                   Arg(lo=0.2, hi=1.5, components=2),
                                   Arg(lo=16.0, hi=1024.0, components=2)),
               atol=2e-3, rtol=1e-5, measured="max abs 2e-4 on llvmpipe (pixels <= 2600)",
               envelope="three dots (5 roundings each on values <= 9, relative to the terms, "
                        "not the result), a 2.5 ulp division by depth x tan >= 0.04, then x 0.5 "
                        "+ 0.5, x resolution <= 1024: ~10 ulp of terms up to 9 / 0.04 x 1024: "
                        "1e-3 abs in pixels",
               prepare=_camera_frames),
    ParityCase("contact_occluded", (Arg(lo=0.0, hi=4.0), Arg(lo=0.0, hi=4.0,
                                                             adversarial=(0.0,)),
                                    Arg(lo=0.0, hi=0.1), Arg(lo=0.1, hi=2.0)),
               atol=0.0, rtol=0.0, measured="exact on llvmpipe",
               envelope="exact: one difference compared with the same floats (both sides round "
                        "it identically)"),
    ParityCase("contact_jitter", (Arg(kind="int", lo=0, hi=4096, components=2),),
               atol=1.7e-3, rtol=0.0, period=1.0,
               measured="max abs ~2e-6 on llvmpipe, 1.6e-3 on the H200",
               envelope="fract of 52.98 x fract(x 0.067 + y 0.0058) at pixel centres <= 4096: "
                        "the inner sum reaches 300, where a float's spacing is 2^-15; a GPU may "
                        "fuse either product into the sum (FMA), which moves it by up to two "
                        "half-spacings, 3.05e-5, and 52.98 x 3.05e-5 = 1.62e-3 (+ the outer "
                        "product's 2e-6); compared modulo 1: a fract that wraps on one side "
                        "only is the same phase"),
]
