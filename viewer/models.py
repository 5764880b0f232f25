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
    needs: frozenset[str]  # subset of {"sh", "prefiltered", "dfg", "radiance", "cdf"}
    # how the model treats a scene's [light]: "shaded" (the analytic direct term), "unlit" (no
    # lighting at all) or "ignored" (the neural models: trained under environment light only;
    # the renderer warns once when a scene with a light is rendered with one)
    directional_light: str = "shaded"


MODELS: dict[str, ModelInfo] = {
    m.name: m for m in (
        ModelInfo("unlit", "passes/shade_unlit.frag",
                  "albedo (a splat's baked colour) without lighting, for inspection",
                  frozenset({"radiance"}), directional_light="unlit"),
        ModelInfo("blinn_phong", "passes/shade_blinn_phong.frag",
                  "the thesis baseline: Lambert diffuse from SH irradiance + a Fresnel-free "
                  "normalised Blinn-Phong lobe from the prefiltered environment",
                  frozenset({"sh", "prefiltered", "radiance"})),
        ModelInfo("ggx_split_sum", "passes/shade_ggx_split_sum.frag",
                  "Cook-Torrance GGX, height-correlated Smith, Schlick Fresnel; split-sum "
                  "prefiltered specular + SH diffuse; optional multiple-scattering compensation",
                  frozenset({"sh", "prefiltered", "dfg", "radiance"})),
        ModelInfo("ggx_mc", "passes/shade_ggx_mc.frag",
                  "Monte-Carlo reference of the same BRDF (GGX + Lambert) against the environment: "
                  "`samples` per pixel, `sampling` = uniform | cosine | env | brdf | mis, "
                  "progressive accumulation",
                  frozenset({"dfg", "radiance", "cdf"})),
        ModelInfo("neural", "passes/shade_neural.frag",
                  "the distilled neural shader (thesis ch. 4 student): one small MLP per pixel on "
                  "the material, n.v, SH irradiance and prefiltered radiance; weights baked into "
                  "generated GLSL from `weights` (default: assets/weights)",
                  frozenset({"sh", "prefiltered", "radiance"}), directional_light="ignored"),
        ModelInfo("neural_teacher", "passes/shade_neural_teacher.frag",
                  "the physics-based neural deferred shader (thesis eq. 4.2) in GLSL: diffuse and "
                  "specular MLPs per sampled light direction, `samples` averaged progressively; "
                  "`sampling` uniform | cosine | env (brdf and mis use env)",
                  frozenset({"radiance", "cdf"}), directional_light="ignored"),
    )
}
SAMPLINGS = ("uniform", "cosine", "env", "brdf", "mis")
SAMPLING_MODELS = frozenset({"ggx_mc", "neural_teacher"})  # models that integrate by Monte Carlo (accumulate samples)


def model_info(name: str) -> ModelInfo:
    from .errors import SceneError

    if name not in MODELS:
        raise SceneError(f"unknown shading model {name!r} (known: {', '.join(MODELS)})",
                         where="model")
    return MODELS[name]
