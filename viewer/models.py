"""The shading models: one record per model owns everything the renderer, the specialiser, the
twins and the UI need to know about it.

A :class:`ShadingModel` names its lighting pass (``shaders/passes/shade_<name>.frag``), the
environment resources and G-buffer channels it reads, whether it accumulates Monte-Carlo samples,
which network it loads, and how it turns render settings (and the scene's light and content) into
a :class:`ShadeVariant`: the frozen set of prepended defines that selects the compiled program
(and keys the program cache). There are no ``if model in (...)`` chains elsewhere: a new model is
one record here and one pass file.
"""
from __future__ import annotations

from dataclasses import dataclass

from .errors import SceneError
from .lighting.lights import light_defines
from .scene.settings import FrameFacts, dormant_settings

SAMPLINGS = ("uniform", "cosine", "env", "brdf", "mis")
SAMPLING_IDS = {name: i for i, name in enumerate(SAMPLINGS)}  # the SAMPLING define
MIS_POWERS = {"balance": 1, "power": 2}  # the MIS_POWER define (beta of the power heuristic)
# neural_teacher's samples per pixel when a scene sets none ([render] samples unset), measured
# against 1024-4096 spp (docs/explanation/neural.md): relative RMS error and the share of surface
# pixels whose luminance is off by > 50 % (speckles) on the demo at 160 x 100 - 1.10 / 77 % at
# 1 spp, 0.048 / 0 at 64 - and on the parity scene's sky with its sharp sun at 32 x 24 - 2.36 /
# 92 % at 1, 0.13 / 20 % at 64, 0.027 / 1.2 % at 256, 0.010 / 0 at 1024. 256: clean on both
# (2.3 s at 160 x 100 on llvmpipe; the viewer accumulates it over frames)
TEACHER_SAMPLES = 256
ALL_CHANNELS = None  # ShadingModel.reads: every G-buffer channel


@dataclass(frozen=True)
class ShadeVariant:
    """One compiled variant of a lighting pass: the model and its prepended defines (sorted).
    Frozen and hashable, so it is the program-cache key."""

    model: str
    define_items: tuple[tuple[str, int], ...]

    @property
    def defines(self) -> dict[str, int]:
        return dict(self.define_items)

    def with_defines(self, extra: dict[str, int]) -> ShadeVariant:
        """This variant with ``extra`` defines added (or overriding)."""
        return ShadeVariant(self.model, tuple(sorted({**self.defines, **extra}.items())))


@dataclass(frozen=True)
class ShadingModel:
    name: str
    pass_file: str
    summary: str
    # environment resources: subset of {irradiance, prefiltered, dfg, radiance, cdf}
    needs: frozenset[str]
    # G-buffer channels read besides albedo and alpha (None: all of them)
    reads: frozenset[str] | None = ALL_CHANNELS
    accumulates: bool = False  # Monte Carlo: `samples` accumulate in batches and over frames
    # samples per pixel when the scene sets none ([render] samples unset; sample_count)
    samples: int = 1
    network: str | None = None  # "student" | "teacher": the weights file the model loads
    # how the model treats a scene's punctual lights (viewer.lighting.lights): "shaded" (the analytic
    # direct term of each: LIGHT_COUNT, LIGHT_POSITIONAL), "unlit" (no lighting at all) or
    # "ignored" (the neural teacher: trained under environment light only; the renderer warns
    # once when a scene with lights is rendered with it)
    lights: str = "shaded"
    occlusion: bool = True  # honours `ao` (the G-buffer's) and `ssao` (USE_AO, USE_SSAO)
    # the occlusion also scales its prefiltered specular light ([render] specular_occlusion:
    # SPECULAR_OCCLUSION, compiled in where some occlusion is)
    specular_occlusion: bool = False
    multiscatter: bool = False  # has the GGX energy compensation switch (MULTISCATTER)
    # Monte-Carlo strategies it implements: SAMPLINGS, or a prefix of it (a request past the
    # prefix falls back to its last entry: the teacher has no BRDF pdf, brdf and mis use env)
    samplings: tuple[str, ...] = ()
    specular_lobe: bool = False  # SPECULAR_LOBE 0 compiles out its specular lookups (specialise)
    # SUN_LIGHT: shades the environment's extracted sun analytically (viewer/environment/sun.py) and reads
    # the IBL of the environment without it (GPUResources.ibl(..., sun=True))
    analytic_sun: bool = False
    # ENV_SHADOWS: the environment's shadow directions occlude its irradiance-map diffuse light
    # ([render] env_shadows; passes/lights.glsl env_shadow)
    env_shadows: bool = False
    # rays against the scene's triangles (viewer/raytrace, passes/raytrace.glsl): every light's
    # visibility is traced, so no shadow maps, contact shadows or occlusion terms are compiled in
    traced: bool = False
    # RT_LIGHT: takes the real-time tier's ray-traced visibility and bounce ([render] raytrace,
    # passes/rt_light.glsl) in place of screen-space occlusion and the environment's shadow maps
    ray_light: bool = False

    def variant(self, settings, light=None, specular: bool = True,
                sun: int = 0, contact: bool = False, traceable: bool = True) -> ShadeVariant:
        """The program variant for render ``settings``, the scene's ``light`` (a
        :class:`~viewer.lighting.lights.Light`, a tuple of them or None), whether any surface has a specular
        lobe (:class:`viewer.specialize.SceneFeatures`) and how many compact lights the environment
        has (``sun``: :func:`viewer.environment.sun.extract_lights`, the sun first; a bool counts as one;
        shaded analytically when ``settings.sun``: SUN_LIGHT for the first, ENV_LIGHTS = the
        others' count, compiled in only when there are others); ``contact``: the lights'
        screen-space contact shadows (CONTACT_SHADOWS: :func:`contact_shadows`); ``traceable``:
        the scene has triangles for rays (RT_LIGHT needs them)."""
        d = {"BACKGROUND_ENVIRONMENT": int(settings.display.background == "environment")}
        if self.lights == "shaded":
            d.update(light_defines(light, shadows=settings.shadow.enabled and not self.traced))
            if contact and d["LIGHT_COUNT"] > 0 and not self.traced:
                d["CONTACT_SHADOWS"] = 1
        rt = self.ray_light and settings.raytrace.enabled and traceable
        if rt:
            d["RT_LIGHT"] = 1
        if self.occlusion:
            d["USE_AO"] = int(settings.ao)
            d["USE_SSAO"] = int(settings.ssao.enabled and not rt)  # rays stand in for it
            if self.specular_occlusion and settings.specular_occlusion \
                    and (d["USE_AO"] or d["USE_SSAO"]):
                d["SPECULAR_OCCLUSION"] = 1
        if self.multiscatter:
            d["MULTISCATTER"] = int(settings.multiscatter)
        if self.samplings:
            d["SAMPLING"] = min(SAMPLING_IDS[settings.mc.sampling], len(self.samplings) - 1)
            if self.samplings == SAMPLINGS:
                d["MIS_POWER"] = MIS_POWERS[settings.mc.mis_heuristic]
        if self.specular_lobe:
            d["SPECULAR_LOBE"] = int(specular)
        if self.analytic_sun:
            d["SUN_LIGHT"] = int(bool(sun) and settings.sun)
        elif self.network == "student" and sun and settings.sun:
            # a student whose split-sum base shades the sun (weights "sun": true; the caller
            # decides: viewer.neural.shades_sun); others keep their defines (shade_neural.frag's
            # SUN_LIGHT defaults to 0)
            d["SUN_LIGHT"] = 1
        if d.get("SUN_LIGHT") and int(sun) > 1:
            d["ENV_LIGHTS"] = int(sun) - 1  # the environment's other compact lights
        if self.env_shadows and settings.shadow.enabled and settings.shadow.environment > 0 \
                and not rt:
            d["ENV_SHADOWS"] = int(settings.shadow.environment)
        if d.get("SUN_LIGHT") and rt and not d.get("ENV_LIGHTS"):
            d["RT_SUN"] = 1  # the sun's visibility is a ray towards its disc (rt_light.frag)
        elif d.get("SUN_LIGHT") and settings.shadow.enabled:
            d["SUN_SHADOW"] = 1  # the analytic sun reads a shadow map (viewer/passes/shadow.py)
        return ShadeVariant(self.name, tuple(sorted(d.items())))


_LIT = frozenset({"normal", "roughness", "metallic", "specular", "ao"})

MODELS: dict[str, ShadingModel] = {
    m.name: m for m in (
        ShadingModel("unlit", "passes/shade_unlit.frag",
                     "albedo (a splat's baked colour) without lighting, for inspection",
                     frozenset({"radiance"}), reads=frozenset(), lights="unlit",
                     occlusion=False),
        ShadingModel("blinn_phong", "passes/shade_blinn_phong.frag",
                     "the thesis baseline: Lambert diffuse from the irradiance map + a "
                     "Fresnel-free normalised Blinn-Phong lobe from the prefiltered environment",
                     frozenset({"irradiance", "prefiltered", "radiance"}), reads=_LIT,
                     specular_lobe=True, env_shadows=True, ray_light=True),
        ShadingModel("ggx_split_sum", "passes/shade_ggx_split_sum.frag",
                     "Cook-Torrance GGX, height-correlated Smith, Schlick Fresnel; split-sum "
                     "prefiltered specular + irradiance-map diffuse; the environment's compact "
                     "lights, when it has any, as analytic lights; optional multiple-scattering "
                     "compensation",
                     frozenset({"irradiance", "prefiltered", "dfg", "radiance"}), reads=_LIT,
                     multiscatter=True, specular_lobe=True, analytic_sun=True,
                     env_shadows=True, ray_light=True, specular_occlusion=True),
        ShadingModel("ggx_mc", "passes/shade_ggx_mc.frag",
                     "Monte-Carlo reference of the same BRDF (GGX + Lambert) against the "
                     "environment: `samples` per pixel, `sampling` = uniform | cosine | env | "
                     "brdf | mis, progressive accumulation",
                     frozenset({"dfg", "radiance", "cdf"}), accumulates=True, multiscatter=True,
                     samplings=SAMPLINGS),
        ShadingModel("path", "passes/shade_path.frag",
                     "a progressive path tracer of the same BSDF against the scene's triangles "
                     "(a BVH traversed in GLSL): next-event estimation of the environment (MIS) "
                     "and of every light with shadow rays, `max_depth` segments, Russian "
                     "roulette; converges to `relight reference`",
                     frozenset({"dfg", "radiance", "cdf"}), accumulates=True, multiscatter=True,
                     occlusion=False, traced=True),
        ShadingModel("neural", "passes/shade_neural.frag",
                     "the distilled neural shader (thesis ch. 4 student): one small MLP per "
                     "pixel on the material, n.v, irradiance and prefiltered radiance; "
                     "weights baked into generated GLSL from `weights` (default: assets/weights)",
                     frozenset({"irradiance", "prefiltered", "radiance"}), network="student",
                     ray_light=True, specular_occlusion=True),
        ShadingModel("neural_teacher", "passes/shade_neural_teacher.frag",
                     "the physics-based neural deferred shader (thesis eq. 4.2) in GLSL: diffuse "
                     "and specular MLPs per sampled light direction, `samples` averaged "
                     "progressively; `sampling` uniform | cosine | env (brdf and mis use env)",
                     frozenset({"radiance", "cdf"}), accumulates=True, network="teacher",
                     lights="ignored", occlusion=False, samplings=SAMPLINGS[:3],
                     samples=TEACHER_SAMPLES),
    )
}
# models that integrate by Monte Carlo (accumulate samples)
SAMPLING_MODELS = frozenset(name for name, m in MODELS.items() if m.accumulates)


def sample_count(settings) -> int:
    """Samples per pixel a frame of ``settings`` accumulates: ``[render] samples``, else its
    model's own count (:attr:`ShadingModel.samples`)."""
    if settings.mc.samples is not None:
        return int(settings.mc.samples)
    return model_info(settings.model).samples


def model_info(name: str) -> ShadingModel:
    """The record of model ``name``; an unknown name is a :class:`~viewer.errors.SceneError`."""
    if name not in MODELS:
        raise SceneError(f"unknown shading model {name!r} (known: {', '.join(MODELS)})",
                         where="model")
    return MODELS[name]


def contact_shadows(settings, stacks: bool) -> bool:
    """Whether the lights get screen-space contact shadows (``[render] contact_shadows``):
    ``"on"``, or ``"auto"`` in a scene with image-space stacks (``stacks``: no shadow map holds
    their surfaces, so contact shadows are all the shadow they get)."""
    mode = settings.shadow.contact
    return mode == "on" or (mode == "auto" and stacks)


CLEARCOAT_MODELS = frozenset({"ggx_split_sum", "ggx_mc", "path"})  # shade KHR_materials_clearcoat's coat
TRANSMISSION_MODELS = frozenset({"path"})  # follow light through KHR_materials_transmission


def refracts_forward(model: str) -> bool:
    """Whether ``model`` draws KHR_materials_transmission surfaces in the forward pass, refracting
    a mip-mapped copy of the opaque frame (:mod:`viewer.passes.forward`): every model but those
    that trace them (:data:`TRANSMISSION_MODELS`) and ``unlit`` (no light to refract)."""
    return model not in TRANSMISSION_MODELS | {"unlit"}
SHEEN_MODELS = CLEARCOAT_MODELS  # and KHR_materials_sheen's sheen
ANISOTROPY_MODELS = CLEARCOAT_MODELS  # and KHR_materials_anisotropy's stretched lobe
IRIDESCENCE_MODELS = CLEARCOAT_MODELS  # and KHR_materials_iridescence's thin film


def ignored_settings(model: ShadingModel, asked, settings, variant: ShadeVariant,
                     graph) -> list[tuple[str, str]]:
    """(key, message) for each render setting the user ``asked`` for (the scene's own settings,
    before a network's requirements are added; ``settings``: after) that ``model`` in ``variant``
    leaves unused, so that nothing is dropped silently: ``env_shadows`` on a model without that input;
    under the ray-traced tier (RT_LIGHT) the rasteriser's stand-ins for what its rays trace: the
    environment's shadow maps, screen-space occlusion and its indirect bounce
    (docs/explanation/raytracing.md); and every knob of a part of the frame that the compiled
    ``graph`` does not run (:func:`viewer.scene.settings.dormant_settings`)."""
    facts = FrameFacts.of(settings, model, variant.defines, graph)
    return _superseded(model, asked, variant) + dormant_settings(asked, facts)


def _superseded(model: ShadingModel, asked, variant: ShadeVariant) -> list[tuple[str, str]]:
    k = asked.shadow.environment
    if k > 0 and not model.env_shadows:
        return [(f"env_shadows:{asked.model}",
                 f"model {asked.model!r} does not use env_shadows (the environment's "
                 f"shadows occlude the irradiance-map diffuse light of ggx_split_sum and "
                 f"blinn_phong); rendered without them")]
    if not variant.defines.get("RT_LIGHT"):
        return []
    unused = [name for name, on in (("env_shadows = %d" % k, k > 0),
                                    ("ssao = true", asked.ssao.enabled),
                                    ("indirect = true", asked.ssao.indirect)) if on]
    if not unused:
        return []
    return [(f"rays:{asked.model}:{','.join(unused)}",
             f"{', '.join(unused)} superseded by the ray-traced tier (raytrace = true), whose "
             f"rays trace the environment's occlusion and one bounce; rendered without "
             f"{'it' if len(unused) == 1 else 'them'} (set raytrace = false to use "
             f"{'it' if len(unused) == 1 else 'them'})")]


# (lobe: its G-buffer layout flag with_<lobe>, the models that shade it, its name in the
# warning, what the other models show instead): ignored_lobes
_LAYERED_LOBES = (
    ("clearcoat", CLEARCOAT_MODELS, "the KHR_materials_clearcoat coat",
     "the base is shown uncoated"),
    ("sheen", SHEEN_MODELS, "the KHR_materials_sheen sheen", "the base is shown without it"),
    ("anisotropy", ANISOTROPY_MODELS, "KHR_materials_anisotropy",
     "the specular lobe is shown isotropic"),
    ("iridescence", IRIDESCENCE_MODELS, "the KHR_materials_iridescence thin film",
     "the base is shown without it"),
)


def ignored_lobes(model: ShadingModel, layout) -> list[tuple[str, str]]:
    """``(lobe, warning)`` for each glTF extension lobe the scene's G-buffer ``layout`` carries
    that ``model`` does not shade: the neural models (student and teacher) read Filament's
    specular reflectance only, so they ignore the dielectric lobe of KHR_materials_ior /
    KHR_materials_specular (its ``dielectric`` channel); KHR_materials_transmission surfaces are
    drawn by ``ggx_split_sum`` in the forward pass for the models that cannot run there (the
    Monte-Carlo and network ones); the coat of KHR_materials_clearcoat is
    shaded by :data:`CLEARCOAT_MODELS` only, the sheen of KHR_materials_sheen by
    :data:`SHEEN_MODELS` (``unlit`` shows no light at all)."""
    out = []
    if model.network is not None and layout.with_dielectric:
        out.append(("dielectric", f"model {model.name!r} ignores the KHR_materials_ior / "
                                  f"KHR_materials_specular dielectric lobe (it reads Filament's "
                                  f"specular reflectance: f0 = 0.04 for those materials)"))
    if layout.with_transmission and refracts_forward(model.name) and (
            model.accumulates or model.network is not None):  # passes.forward.forward_model
        out.append(("transmission", f"model {model.name!r} cannot shade surfaces in a forward "
                                    f"pass: KHR_materials_transmission surfaces are shaded by "
                                    f"ggx_split_sum there, refracting a copy of the opaque frame "
                                    f"(traced exactly by "
                                    f"{', '.join(sorted(TRANSMISSION_MODELS))})"))
    for lobe, models, named, shown in _LAYERED_LOBES:
        if getattr(layout, f"with_{lobe}") and model.name not in models | {"unlit"}:
            out.append((lobe, f"model {model.name!r} ignores {named} (shaded by "
                              f"{', '.join(sorted(models))}); {shown}"))
    return out
