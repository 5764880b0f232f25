"""The ``[render]`` table as frozen dataclasses, grouped by the part of the renderer each setting
steers (Monte Carlo, SSAO, the neural models, the display), with the flat TOML keys mapped onto
them (:data:`RENDER_KEYS`). Parsing and validation: :func:`viewer.scene.checks.validate_render`."""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any


@dataclass(frozen=True)
class MonteCarloSettings:
    """How models that integrate by Monte Carlo (``ggx_mc``, ``path``, ``neural_teacher``) sample."""

    # samples per pixel (ignored by 1-sample models); None (unset): the model's own count,
    # viewer.models.ShadingModel.samples (1, but 64 for neural_teacher: docs/explanation/neural.md)
    samples: int | None = None
    sampling: str = "mis"  # strategy: uniform | cosine | env | brdf | mis
    mis_heuristic: str = "power"  # MIS weights: "power" (beta = 2) | "balance"
    seed: int = 0  # scrambles the per-pixel sequences (also SSAO's rays)
    # `path`: segments of a path, the camera's included, as Mitsuba counts them (2: direct light
    # only, 3: one bounce); relight reference's default is 6
    max_depth: int = 6


@dataclass(frozen=True)
class SSAOSettings:
    """Screen-space ambient occlusion and one-bounce indirect light (thesis eqs. 6.19-6.22)."""

    enabled: bool = False  # occlusion on the diffuse term of every model (TOML: ssao)
    indirect: bool = False  # + one-bounce indirect light
    rays: int = 8  # rays per pixel, AO and indirect (TOML: ssao_rays)
    steps: int = 8  # ray-marching steps per ray (ssao_steps)
    radius: float = 0.5  # world units a ray marches (ssao_radius)
    thickness: float = 0.2  # world units: delta of eq. 6.20, assumed thickness (ssao_thickness)
    # 1: every pixel marches; k > 1: one pixel in k x k marches and a joint bilateral filter
    # fills the rest (viewer/passes/ssao.py; about k^2 x cheaper; TOML: ssao_scale, 1..8)
    scale: int = 1
    # a depth- and normal-aware 5 x 5 blur of O(x) against the rays' per-pixel noise
    # (passes/ssao_blur.frag; TOML: ssao_blur)
    blur: bool = True
    # the one-bounce light gathered at full resolution (scale 1) through the same blur before
    # it is added (SSAO_COMPOSITE at k = 1: gather, ssao_blur, composite): the gather's 8 rays
    # a pixel are speckle on a floor, most of the screen-space frame's (TOML:
    # indirect_blur; at k > 1 the joint bilateral upsampling filters it already). On by default
    # since it never lowered a measured score (docs/explanation/models.md)
    indirect_blur: bool = True

    def __bool__(self):  # `if settings.ssao:` would always be true: say where the switch is
        raise TypeError("SSAOSettings has no truth value: use settings.ssao.enabled")


@dataclass(frozen=True)
class RaytraceSettings:
    """The real-time tier's rays (passes/rt_light.frag, viewer/passes/rt_light.py): the
    environment's visibility and one bounce for the rasterised models, traced against the
    scene's triangles, accumulated over still frames and denoised."""

    enabled: bool = True  # (TOML: raytrace)
    rays: int = 1  # diffuse rays per pixel and frame, besides one specular ray (raytrace_rays)
    denoise: bool = True  # the edge-avoiding a-trous filter (ray_denoise)
    # frames a still view accumulates before the history becomes an exponential average of that
    # many (ray_frames)
    frames: int = 32
    # frames of rays a headless (non-progressive) render accumulates at once: its image's noise
    # against its cost, about one viewer frame's rays each (ray_still_frames)
    still_frames: int = 8
    # rays for one pixel in k x k (ray_scale): traced, accumulated and filtered at 1/k^2 of the
    # pixels, then brought to full resolution by SSAO's joint bilateral upsampling
    scale: int = 1

    def __bool__(self):  # say where the switch is
        raise TypeError("RaytraceSettings has no truth value: use settings.raytrace.enabled")


@dataclass(frozen=True)
class NeuralSettings:
    """Which weights the neural models load and where their generated GLSL reads them."""

    # `neural` student weights (.safetensors); None = assets/weights' student for the frame
    # (neural_student, or neural_student_visibility where shadow_net_use = "visibility":
    # viewer.neural.network.student_path)
    weights: str | None = None
    teacher_weights: str | None = None  # `neural_teacher` weights; None = assets/weights
    # the neural shadow estimator's weights (viewer/neural/shadow_net.py): its visibility
    # multiplies every model's shading (thesis eq. 4.3); None: no estimator (TOML: shadow_net)
    shadow_net: str | None = None
    # how its visibility V enters the frame: "product" (multiplied into the shaded radiance,
    # thesis eq. 4.3; every model) | "visibility" (the mean of V's colours in place of SSAO's
    # occlusion O(x) and a student's S(x) in the lighting pass: blinn_phong, ggx_split_sum,
    # neural; viewer/graph/shadow_net.py); TOML: shadow_net_use
    shadow_net_use: str = "product"
    # "const" (baked) | "ubo" (a uniform block, or a storage buffer above 16 KiB) | "texture"
    # (viewer.neural.WEIGHT_STORAGES); TOML: neural_storage
    storage: str = "const"


@dataclass(frozen=True)
class DisplaySettings:
    """The last pass: linear radiance -> the displayed image."""

    # pbr_neutral (Khronos PBR Neutral: keeps base colours) | aces (Hill's fit) | agx (three.js)
    # | reinhard | none (viewer.scene.checks.TONEMAPS)
    tonemap: str = "pbr_neutral"
    exposure: float = 0.0  # EV stops: radiance * 2^exposure before tone mapping
    background: str = "environment"  # "environment" | "transparent"
    # anti-aliasing of the display image: "fxaa" (FXAA 3.11 after tone mapping; not drawn when
    # supersampled, whose edges are already filtered) | "none"
    aa: str = "fxaa"
    # supersampling: every pass before tone mapping at ssaa x the size, box-averaged in linear
    # radiance (viewer/passes/antialias.py; 1 = off, up to SSAA_MAX)
    ssaa: int = 1


@dataclass(frozen=True)
class ShadowSettings:
    """Shadow maps of the shadowing lights (viewer/passes/shadow.py, lib/shadow.glsl)."""

    enabled: bool = True  # every light with `shadow` set casts a shadow (TOML: shadows)
    size: int = 2048  # texels a side of a directional or spot light's map (shadow_size, 64..8192)
    # texels a side of each of a point light's six cube faces (shadow_cube_size, 32..4096): six
    # faces of half the 2D map's side hold 1.5 x its texels
    cube_size: int = 1024
    # the texels a frame's light maps share, in maps of the sizes above: where more lights cast
    # shadows than that, every light map's side (cube faces too) shrinks by the same factor,
    # sqrt(budget / maps) (viewer/graph/shadows.py budgeted), so the passes draw about one
    # map's texels however many lights there are (four lights: maps of half the side); a lone
    # light keeps its size; 0: no limit (shadow_budget, 0 or 1..SHADOW_BUDGET_MAX)
    budget: float = 1.0
    # scales each light's angular size, so the penumbra (PCSS); 0: hard (shadow_softness)
    softness: float = 1.0
    bias: float = 1.0  # scales the receiver's normal offset (shadow_bias)
    # an image-space stack's depth snapped to its shadow-only proxies' where the two lie within
    # this fraction of the proxies' depth (viewer/geometry/proxy_snap.py: an estimated depth then
    # does not shadow itself at the default bias); 0: off (shadow_proxy_snap, 0..1)
    proxy_snap: float = 0.05
    # the error a mesh drawn into a shadow map may carry, in the map's texels where it lies:
    # each is drawn at the coarsest level of detail within it (viewer/geometry/simplify.py:
    # meshoptimizer's measure; a silhouette moves about twice as far); 0: whole meshes
    # (shadow_lod_error, 0..LOD_ERROR_MAX)
    lod_error: float = 0.5
    # a directional light's (and the sun's) cascaded maps (viewer/lighting/cascades.py): "auto" (only
    # where one map's texels are coarse beside the pixels near the camera), or 1..4 (1: one map)
    # (shadow_cascades)
    cascades: str | int = "auto"
    # screen-space contact shadows (passes/lights.glsl contact_shadow: a march through the
    # G-buffer's depth towards each light): "auto" on image stacks (no shadow map holds them),
    # "on" every surface (meshes too: small-scale detail a map's texels miss), "off"
    # (contact_shadows)
    contact: str = "auto"
    contact_length: float = 0.3  # world units the march covers (contact_length)
    # the environment's light as this many directional lights (viewer/environment/sampling.py median_cut)
    # whose soft shadow maps occlude its diffuse light (passes/lights.glsl env_shadow), in the
    # models that look it up from the irradiance map; 0: none (env_shadows, 0..ENV_SHADOWS_MAX)
    environment: int = 0

    def __bool__(self):
        raise TypeError("ShadowSettings has no truth value: use settings.shadow.enabled")


CONTACT_SHADOWS = ("auto", "on", "off")  # [render] contact_shadows
LOD_ERROR_MAX = 4.0  # [render] shadow_lod_error: 0..4 texels
SHADOW_BUDGET_MAX = 64.0  # [render] shadow_budget: 0 (no limit) or 1..64 maps
ENV_SHADOWS_MAX = 16  # [render] env_shadows: 0..16 (tiles of one shadow atlas, 2 wide)
SPLAT_DEPTHS = ("expected", "median")  # [render] splat_depth (viewer.passes.splats)
SSAO_SCALE_MAX = 8  # [render] ssao_scale: 1..8
RAY_SCALE_MAX = 4  # [render] ray_scale: 1..4 (beyond, the filter's footprint spans 116 pixels)
AA_MODES = ("fxaa", "none")  # [render] aa
SSAA_MAX = 8  # [render] ssaa: 1..8 (ssaa^2 times the pixels of every pass before the resolve)


@dataclass(frozen=True)
class RenderSettings:
    """The ``[render]`` table, grouped by the part of the renderer each setting steers. The TOML
    stays flat: :data:`RENDER_KEYS` maps each key to its place; :meth:`flat` and :meth:`with_flat`
    read and write settings by those keys (``scene.with_render(samples=64)``)."""

    model: str = "ggx_split_sum"
    multiscatter: bool = True  # GGX multiple-scattering energy compensation
    # the environment's compact lights (its sun first, viewer/environment/sun.py) as analytic disc lights in
    # models that shade them (ggx_split_sum, sun students); false: looked up through the
    # prefiltered chain and the irradiance map like the rest of the environment
    sun: bool = True
    ao: bool = True  # apply the G-buffer's ambient occlusion to diffuse light
    # the occlusion (the G-buffer's ao times SSAO's) also takes its share of the environment's
    # specular light, by n.v and roughness (Lagarde 2014, as Filament and three.js do;
    # lib/shading.glsl specular_occlusion), in ggx_split_sum and the neural student's base
    specular_occlusion: bool = True
    precision: str = "fp32"  # G-buffer render targets: "fp32" | "fp16" (radiance stays fp32)
    specialize: bool = True  # build only the channels and shader variants the scene needs
    # splat G-buffer depth: "expected" (eq. 6.10, the blending-weighted mean) | "median" (where
    # the accumulated opacity reaches half the coverage: robust to floaters)
    splat_depth: str = "expected"
    mc: MonteCarloSettings = MonteCarloSettings()
    ssao: SSAOSettings = SSAOSettings()
    neural: NeuralSettings = NeuralSettings()
    display: DisplaySettings = DisplaySettings()
    shadow: ShadowSettings = ShadowSettings()
    raytrace: RaytraceSettings = RaytraceSettings()

    def flat(self) -> dict[str, Any]:
        """Every setting by its TOML key, in :data:`RENDER_KEYS` order."""
        return {key: (getattr(self, field) if group is None
                      else getattr(getattr(self, group), field))
                for key, (group, field) in RENDER_KEYS.items()}

    def with_flat(self, **changes) -> "RenderSettings":
        """A copy with settings changed by TOML key; an unknown key is a ``TypeError``."""
        top: dict[str, Any] = {}
        grouped: dict[str, dict[str, Any]] = {}
        for key, value in changes.items():
            if key not in RENDER_KEYS:
                raise TypeError(f"unknown render setting {key!r} (known: {', '.join(RENDER_KEYS)})")
            group, field = RENDER_KEYS[key]
            if group is None:
                top[field] = value
            else:
                grouped.setdefault(group, {})[field] = value
        for group, fields_ in grouped.items():
            top[group] = replace(getattr(self, group), **fields_)
        return replace(self, **top)


# TOML key of [render] -> (group attribute of RenderSettings or None, field)
RENDER_KEYS: dict[str, tuple[str | None, str]] = {
    "model": (None, "model"),
    "samples": ("mc", "samples"),
    "sampling": ("mc", "sampling"),
    "multiscatter": (None, "multiscatter"),
    "sun": (None, "sun"),
    "ao": (None, "ao"),
    "specular_occlusion": (None, "specular_occlusion"),
    "tonemap": ("display", "tonemap"),
    "exposure": ("display", "exposure"),
    "background": ("display", "background"),
    "aa": ("display", "aa"),
    "ssaa": ("display", "ssaa"),
    "seed": ("mc", "seed"),
    "precision": (None, "precision"),
    "specialize": (None, "specialize"),
    "mis_heuristic": ("mc", "mis_heuristic"),
    "max_depth": ("mc", "max_depth"),
    "ssao": ("ssao", "enabled"),
    "indirect": ("ssao", "indirect"),
    "ssao_rays": ("ssao", "rays"),
    "ssao_steps": ("ssao", "steps"),
    "ssao_radius": ("ssao", "radius"),
    "ssao_thickness": ("ssao", "thickness"),
    "ssao_scale": ("ssao", "scale"),
    "ssao_blur": ("ssao", "blur"),
    "indirect_blur": ("ssao", "indirect_blur"),
    "weights": ("neural", "weights"),
    "teacher_weights": ("neural", "teacher_weights"),
    "shadow_net": ("neural", "shadow_net"),
    "shadow_net_use": ("neural", "shadow_net_use"),
    "neural_storage": ("neural", "storage"),
    "splat_depth": (None, "splat_depth"),
    "shadows": ("shadow", "enabled"),
    "shadow_size": ("shadow", "size"),
    "shadow_cube_size": ("shadow", "cube_size"),
    "shadow_budget": ("shadow", "budget"),
    "env_shadows": ("shadow", "environment"),
    "shadow_softness": ("shadow", "softness"),
    "shadow_bias": ("shadow", "bias"),
    "shadow_proxy_snap": ("shadow", "proxy_snap"),
    "shadow_lod_error": ("shadow", "lod_error"),
    "shadow_cascades": ("shadow", "cascades"),
    "contact_shadows": ("shadow", "contact"),
    "contact_length": ("shadow", "contact_length"),
    "raytrace": ("raytrace", "enabled"),
    "raytrace_rays": ("raytrace", "rays"),
    "ray_denoise": ("raytrace", "denoise"),
    "ray_frames": ("raytrace", "frames"),
    "ray_still_frames": ("raytrace", "still_frames"),
    "ray_scale": ("raytrace", "scale"),
}


# [render] keys that only tune one part of the frame, by that part: (keys, what they tune,
# whether this frame runs it: frame -> bool, frame a FrameFacts)
TUNING_KEYS = (
    (("raytrace_rays", "ray_denoise", "ray_frames", "ray_still_frames", "ray_scale"),
     "the ray-traced tier (raytrace = true, a model it lights: blinn_phong, ggx_split_sum or "
     "neural, and meshes or splats to trace)", lambda f: "raytrace" in f.passes),
    (("ssao_rays", "ssao_steps", "ssao_radius", "ssao_thickness", "ssao_scale"),
     "the SSAO pass and its bounce (ssao or indirect = true, without the ray-traced tier)",
     lambda f: "ssao" in f.passes or "indirect_gather" in f.passes),
    (("ssao_blur",), "the SSAO pass's occlusion (ssao = true, without the ray-traced tier)",
     lambda f: "ssao" in f.passes),
    (("indirect_blur",), "the screen-space bounce (indirect = true, without the ray-traced tier)",
     lambda f: "indirect" in f.passes),
    (("shadow_net_use",), "the shadow estimator (shadow_net = FILE)",
     lambda f: any(p.startswith("shadow_net") for p in f.passes)),
    # (not shadow_proxy_snap: the G-buffer pass snaps an image stack's depth with it, rays or not)
    (("shadow_size", "shadow_cube_size", "shadow_budget", "shadow_softness", "shadow_bias",
      "shadow_lod_error", "shadow_cascades"),
     "the shadow maps (shadows = true and a light or sun whose shadow is not traced)",
     lambda f: any(p.startswith("shadow") and not p.startswith("shadow_net")
                   for p in f.passes)),
    (("specular_occlusion",), "the occlusion of a split-sum model's environment light "
     "(ggx_split_sum or neural, with ao or ssao)",
     lambda f: f.model.specular_occlusion
     and bool(f.defines.get("USE_AO") or f.defines.get("USE_SSAO"))),
    (("contact_length",), "the contact shadows (contact_shadows, a model that shades lights)",
     lambda f: bool(f.defines.get("CONTACT_SHADOWS"))),
    (("samples",), "the Monte-Carlo models (ggx_mc, path, neural_teacher; the others draw 1)",
     lambda f: f.model.accumulates or f.settings.mc.samples == 1),
    (("sampling",), "the sampled models (ggx_mc, neural_teacher)",
     lambda f: "SAMPLING" in f.defines),
    (("mis_heuristic",), "ggx_mc's multiple importance sampling (sampling = \"mis\")",
     lambda f: f.defines.get("SAMPLING") == 4),
    (("max_depth",), "the path tracer (model = \"path\")", lambda f: f.model.name == "path"),
    (("weights",), "the neural student (model = \"neural\")",
     lambda f: f.model.network == "student"),
    (("teacher_weights",), "the neural teacher (model = \"neural_teacher\")",
     lambda f: f.model.network == "teacher"),
    (("neural_storage",), "the neural models' weights in GLSL (model = \"neural\" or "
     "\"neural_teacher\")", lambda f: f.model.network is not None),
)


@dataclass(frozen=True)
class FrameFacts:
    """What one frame runs, for :func:`dormant_settings`: its settings (a network's needs added),
    its shading model (:class:`viewer.models.ShadingModel`), the lighting pass's defines and the
    names of the frame graph's passes."""

    settings: "RenderSettings"
    model: Any
    defines: dict
    passes: frozenset

    @classmethod
    def of(cls, settings, model, defines: dict, graph) -> "FrameFacts":
        """From a compiled frame graph (``viewer.graph``), its passes by name."""
        return cls(settings, model, defines, frozenset(p.name for p in graph.passes))


def dormant_keys(frame: FrameFacts) -> dict[str, str]:
    """Every key of :data:`TUNING_KEYS` whose part ``frame`` does not run, with what it tunes
    (the viewer's panel greys those knobs)."""
    return {k: what for keys, what, runs in TUNING_KEYS if not runs(frame) for k in keys}


def dormant_settings(asked: RenderSettings, frame: FrameFacts) -> list[tuple[str, str]]:
    """(key, message) for each setting the scene ``asked`` for away from its default that tunes
    a part of the frame it does not run (:data:`TUNING_KEYS`), so that a knob with no effect is
    said, not dropped silently (``--set ray_scale=2`` with ``raytrace = false``). The key of
    each is the knobs' names, not their values: said once per process
    (:func:`viewer.renderer._warn_once`) however a slider moves them."""
    default, mine, idle = RenderSettings().flat(), asked.flat(), dormant_keys(frame)
    out = []
    for keys, what, _ in TUNING_KEYS:
        changed = [k for k in keys if k in idle and not _same(mine[k], default[k])]
        if changed:
            shown = " and ".join(f"render.{k} = {_toml(mine[k])}" for k in changed)
            one = len(changed) == 1
            out.append((f"dormant:{','.join(changed)}",
                        f"{shown} {'has' if one else 'have'} no effect: "
                        f"{'it tunes' if one else 'they tune'} {what}, which this frame does "
                        f"not run"))
    return out


def _same(a, b) -> bool:
    """Equal, a float to 1e-6 of its size: a slider's float32 0.2 is the default 0.2."""
    if isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
        return abs(a - b) <= 1e-6 * max(abs(a), abs(b), 1.0)
    return a == b


def _toml(value) -> str:
    return str(value).lower() if isinstance(value, bool) else \
        f'"{value}"' if isinstance(value, str) else f"{value:.6g}" if isinstance(value, float) \
        else str(value)
