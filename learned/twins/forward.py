"""Twin of the forward pass for transparent surfaces (``viewer/passes/forward.py`` with
``shaders/passes/forward_surface.glsl``): each blended surface, given as its own G-buffer layer,
shaded by the lighting-pass twin (:func:`learned.twins.shade.shade`), depth-tested against the
opaque G-buffer and put "over" the shaded radiance back to front. Images in GL row order (row 0
at the bottom), as :mod:`learned.twins.shade`.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

from .shade import shade


@dataclass
class ForwardLayer:
    """One blended mesh as the twin sees it."""

    gbuffer: dict[str, torch.Tensor]  # the mesh alone as a G-buffer: channel -> [H, W, C]
    alpha: float  # its glTF alpha (baseColorFactor.a x COLOR_0 alpha; constant over the mesh)
    centre_depth: float  # view depth (-z_vs) of its bounding-box centre: the sort key


def forward_order(centre_depths: list[float]) -> list[int]:
    """``viewer.passes.forward.forward_order``: indices back to front (largest view depth first),
    equal depths in their given order (a stable sort)."""
    return sorted(range(len(centre_depths)), key=lambda i: -float(centre_depths[i]))


def blend_over(src: torch.Tensor, dst: torch.Tensor) -> torch.Tensor:
    """The fixed-function blend of the forward pass, (ONE, ONE_MINUS_SRC_ALPHA) on colour and
    alpha: premultiplied ``src`` [..., 4] over ``dst`` [..., 4] = src + (1 - src.a) dst."""
    return src + (1.0 - src[..., 3:4]) * dst


def forward_visible(layer: dict[str, torch.Tensor], opaque: dict[str, torch.Tensor]
                    ) -> torch.Tensor:
    """``forward_surface.glsl``'s depth test: [H, W] bool, where the layer covers the pixel and is
    nearer than the opaque G-buffer's surface there (or the pixel has none)."""
    covered = layer["alpha"][..., 0] > 0.0
    nearer = (opaque["alpha"][..., 0] <= 0.0) | (layer["depth"][..., 0] < opaque["depth"][..., 0])
    return covered & nearer


def shade_forward(model: str, radiance: torch.Tensor, opaque: dict[str, torch.Tensor],
                  layers: list[ForwardLayer], camera, env: dict, intensity: float,
                  rotation_rad: float, defines: dict[str, int], light=None,
                  envelope: dict | None = None) -> torch.Tensor:
    """The forward pass over ``radiance`` ([H, W, 4], the deferred passes' output).

    ``model`` and ``defines``: the lighting pass that shades blended surfaces
    (``viewer.passes.forward.forward_model`` / ``forward_variant``: BACKGROUND_ENVIRONMENT 0, so
    :func:`shade` returns the premultiplied colour c alpha); ``opaque``: the opaque G-buffer;
    ``env``, ``intensity``, ``rotation_rad``, ``light``: as :func:`shade`. Each layer's coverage
    becomes its alpha where it passes the depth test, 0 elsewhere, and its shaded colour is
    blended over the result so far, farthest layer first. ``envelope`` (a dict, filled in):
    ``"bound"`` [H, W, 3], the sum of the layers' lookup envelopes (each blend step scales what
    is under it by 1 - alpha <= 1, so the sum bounds the total).
    Returns [H, W, 4]: radiance and coverage.
    """
    out = radiance
    bound = torch.zeros_like(radiance[..., :3])
    for index in forward_order([layer.centre_depth for layer in layers]):
        layer = layers[index]
        g = dict(layer.gbuffer)
        visible = forward_visible(g, opaque)
        a = torch.where(visible, torch.full_like(g["alpha"][..., 0], min(max(layer.alpha, 0.0),
                                                                         1.0)),
                        torch.zeros_like(g["alpha"][..., 0]))
        g["alpha"] = a[..., None]
        if "color" in g:  # the unlit colour channel is premultiplied by coverage
            g["color"] = g["albedo"] * g["alpha"]
        layer_envelope = None if envelope is None else {k: v for k, v in envelope.items()
                                                        if k == "weight_bits"}
        src = shade(model, g, camera, env, intensity, rotation_rad, defines, light=light,
                    envelope=layer_envelope)
        out = blend_over(src, out)
        if layer_envelope is not None:
            bound = bound + layer_envelope["bound"]
    if envelope is not None:
        envelope["bound"] = bound
    return out
