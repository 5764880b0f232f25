"""The classical model given the student's evidence, in torch over the same inputs.

The student reads the screen-space visibility of the environment's light S(x) (the SSAO pass's
``SSAO_ENV_VIS`` channel), the SSAO occlusion O(x), the analytic sun and the screen-space
one-bounce light L_ind. A fair baseline may use all of them. Each :class:`Classical` variant is
the split-sum model (the student's own base at k = 0.5, :mod:`learned.twins.neural`: diffuse SH
irradiance x (1 - E_spec), GGX-prefiltered radiance along the dominant direction x DFG) with:

- ``sun``: the environment's sun taken out of the IBL and shaded as a light (``SUN_LIGHT``);
- ``multiscatter``: the multiple-scattering compensation of the specular terms (the path-traced
  truth's BSDF scatters multiply);
- ``ssao``: the diffuse term times the material AO x O(x) (else the material AO alone);
- ``vis``: which terms S(x) multiplies: ``""`` none, ``"d"`` the diffuse IBL, ``"ds"`` the
  diffuse and specular IBL, ``"dsl"`` those and the sun light;
- ``indirect``: plus L_ind (the indirect pass's one-bounce light, gathered from the split-sum
  base's direct light with multiple scattering);
- ``specular_occlusion``: the prefiltered specular light times the occlusion's share of it
  (:func:`learned.twins.shading.specular_occlusion` of the same AO: the material's, times O(x)
  with ``ssao``), as ``[render] specular_occlusion`` (on by default since 2026-11-29; the
  variants scored before had none: ``"specular_occlusion": false`` reproduces them).

:func:`variants` lists them all; the protocol scores every variant on the validation split and
takes the best (:mod:`learned.protocol.run`), so the student faces the strongest classical model
that the same evidence allows, chosen without the test set.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import torch

from learned.twins.brdf import clamp_perceptual_roughness, compute_f0, f90_from_f0
from learned.twins.ibl import ibl_energy_compensation
from learned.twins.neural import neural_student_radiance_split, neural_student_sun_split
from learned.twins.shading import diffuse_color

from ..neural.lighting import student_features

VIS_TERMS = ("", "d", "ds", "dsl")


@dataclass(frozen=True)
class Classical:
    sun: bool = False
    multiscatter: bool = True
    ssao: bool = True
    vis: str = ""
    indirect: bool = True
    specular_occlusion: bool = True

    @property
    def name(self) -> str:
        parts = ["split-sum"]
        if self.sun:
            parts.append("sun light")
        if self.multiscatter:
            parts.append("ms")
        if self.ssao:
            parts.append("SSAO")
        if self.vis:
            parts.append(f"S(x) on {'+'.join({'d': 'diff', 's': 'spec', 'l': 'sun'}[c] for c in self.vis)}")
        if self.indirect:
            parts.append("indirect")
        if self.specular_occlusion:
            parts.append("spec. occlusion")
        return " + ".join(parts)


# the classical renderer's default with its screen-space passes (ggx_split_sum + SSAO +
# indirect, multiple scattering and specular occlusion on; no S(x), the sun inside the IBL)
DEFAULT = Classical()


def variants() -> list[Classical]:
    """Every distinct variant (the sun light's ``"dsl"`` only with ``sun``)."""
    out = []
    for sun, ms, ssao, vis, ind, so in product((False, True), (False, True), (False, True),
                                               VIS_TERMS, (False, True), (False, True)):
        if vis == "dsl" and not sun:
            continue
        out.append(Classical(sun, ms, ssao, vis, ind, so))
    return out


_HALF = 0.5  # k = 0.5: S k = 1, the classical term (NEURAL_OUTPUT_SCALE 2)


@torch.no_grad()
def classical_radiance(model: Classical, img) -> torch.Tensor:
    """``model``'s radiance ``[P, 3]`` at the foreground pixels of ``img``
    (:class:`learned.train.TrainImage` loaded with ``sun=True, multiscatter=True``)."""
    lighting = img.lighting_sun if model.sun else img.lighting
    if lighting is None:
        raise ValueError("a classical model with the sun needs load_images(..., sun=True)")
    ao = img.gb["ao"][:, 0] * (img.ssao if model.ssao else 1.0)
    feats = student_features(img.gb, img.v, lighting, ao, img.vis, dominant=True, sun=model.sun,
                             specular_occlusion=model.specular_occlusion)
    x, irradiance, prefiltered = feats[:3]
    albedo, metallic, specular = x[:, :3], x[:, 4], x[:, 5]
    dfg = x[:, 8:10]
    f0 = compute_f0(albedo, metallic, specular)
    f90 = f90_from_f0(f0)
    diffuse = diffuse_color(albedo, metallic)
    scale = ibl_energy_compensation(dfg, f0) if model.multiscatter else torch.ones_like(f0)
    zero = torch.zeros_like(ao)
    k_d = torch.stack([_HALF * ao, zero, zero], -1)
    k_s = torch.stack([zero, zero + _HALF, zero + _HALF], -1)
    vis = img.vis[:, None]
    d = neural_student_radiance_split(k_d, diffuse, f0, f90, dfg, irradiance, prefiltered, scale)
    s = neural_student_radiance_split(k_s, diffuse, f0, f90, dfg, irradiance, prefiltered, scale)
    out = d * (vis if "d" in model.vis else 1.0) + s * (vis if "s" in model.vis else 1.0)
    if model.sun:
        sun = feats[3]
        a = clamp_perceptual_roughness(x[:, 3]) ** 2
        args = (sun[:, 0:3], sun[:, 3:6], sun[:, 6:9], sun[:, 9:12], sun[:, 12], scale)
        light = (neural_student_sun_split(k_d, diffuse, f0, f90, dfg, a, *args)
                 + neural_student_sun_split(k_s, diffuse, f0, f90, dfg, a, *args))
        out = out + light * (vis if "l" in model.vis else 1.0)
    if model.indirect and img.indirect is not None:
        out = out + img.indirect
    return out
