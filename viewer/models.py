"""The shading models: one lighting pass each (``shaders/passes/shade_<name>.frag``).

``needs`` lists the environment resources a model reads, so a scene builds only those.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ModelInfo:
    name: str
    pass_file: str
    summary: str
    needs: frozenset[str]  # subset of {"sh", "prefiltered", "dfg", "radiance"}


MODELS: dict[str, ModelInfo] = {
    m.name: m for m in (
        ModelInfo("unlit", "passes/shade_unlit.frag",
                  "albedo (a splat's baked colour) without lighting, for inspection",
                  frozenset({"radiance"})),
        ModelInfo("blinn_phong", "passes/shade_blinn_phong.frag",
                  "the thesis baseline: Lambert diffuse from SH irradiance + a Fresnel-free "
                  "normalised Blinn-Phong lobe from the prefiltered environment",
                  frozenset({"sh", "prefiltered", "radiance"})),
        ModelInfo("ggx_split_sum", "passes/shade_ggx_split_sum.frag",
                  "Cook-Torrance GGX, height-correlated Smith, Schlick Fresnel; split-sum "
                  "prefiltered specular + SH diffuse; optional multiple-scattering compensation",
                  frozenset({"sh", "prefiltered", "dfg", "radiance"})),
    )
}
SAMPLINGS = ("uniform", "cosine", "env", "brdf", "mis")


def model_info(name: str) -> ModelInfo:
    from .errors import SceneError

    if name not in MODELS:
        raise SceneError(f"unknown shading model {name!r} (known: {', '.join(MODELS)})",
                         where="model")
    return MODELS[name]
