"""Environment lighting for the neural shaders, in torch: the same resources the GLSL passes read.

A :class:`Lighting` holds what ``viewer.environment.ibl.build_ibl`` and ``viewer.environment.sampling`` computed on the
GPU, read back (so torch and GLSL see identical textures): level 0 of the equirect radiance, the
prefiltered chain, SH irradiance coefficients and the importance-sampling tables. Per-pixel inputs
are flattened: a G-buffer is a dict channel -> ``[N, C]`` and ``v`` the unit directions towards the
viewer ``[N, 3]`` (world space).

Torch only, nothing of the GL side: the twins (``learned.twins.neural``) import this module, and
``tests/test_layering.py`` holds their whole import chain off ``viewer``. Reading a renderer's
IBL back into a :class:`Lighting` is :func:`learned.neural.lighting.lighting_from_gl`.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import torch

from learned.twins.brdf import clamp_perceptual_roughness
from learned.twins.deferred import env_dir, reflect
from learned.twins.env_sampling import sample_env
from learned.twins.ground import LUMA  # Rec. 709, as the GLSL
from learned.twins.equirect import equirect_uv, rotate_y
from learned.twins.ibl import (
    ibl_dfg,
    ibl_dominant_factor,
    ibl_specular_radiance,
    ibl_specular_radiance_sun,
    irradiance_lookup,
    sample_bilinear,
    specular_dominant_direction,
)
from learned.twins.mc import sample_cosine_hemisphere, sample_uniform_hemisphere
from learned.twins.sampling import tangent_to_world
from learned.twins.shading import disc_light, shading_normal, sun_specular_weight
from learned.twins.shading import specular_occlusion as occluded_share

# sampling strategy ids of shade_neural_teacher.frag (SAMPLING define)
STRATEGIES = {"uniform": 0, "cosine": 1, "env": 2}


@dataclass
class Lighting:
    radiance: torch.Tensor  # [h, w, 4] level 0 of the equirect radiance (environment frame)
    prefiltered: list  # [h_k, w_k, 4] per level
    levels: float
    sh: torch.Tensor  # [9, 3]
    irradiance: torch.Tensor  # [h, w, 4] the irradiance map (lib/ibl.glsl irradiance_lookup)
    marginal: torch.Tensor  # [h + 1]
    conditional: torch.Tensor  # [h, w + 1]
    pdf: torch.Tensor  # [h, w] density on the uv square
    intensity: float = 1.0
    rotation: float = 0.0  # radians about +Y
    dfg: torch.Tensor | None = None  # [n, n, 2] split-sum LUT (x = n.v, y = perceptual roughness)
    dominant: torch.Tensor | None = None  # [n, n, 1] the dominant direction's lerp factor LUT
    # the environment's compact sun (viewer.environment.sun.Sun) when this is the IBL without it (SUN_LIGHT:
    # prefiltered levels and SH leave it out, learned.neural.lighting.lighting_from_gl(..., sun=True)), else None
    sun: object | None = None
    prefiltered_full: list | None = None  # with a sun: the whole environment's prefiltered chain
    # every compact light taken out with the sun (viewer.environment.sun.extract_lights), the sun first
    lights: tuple = ()

    def with_light(self, intensity: float, rotation: float) -> "Lighting":
        return dataclasses.replace(self, intensity=float(intensity), rotation=float(rotation))


def env_radiance(lighting: Lighting, l_ws: torch.Tensor) -> torch.Tensor:
    """GLSL ``textureLod(u_env_radiance, equirect_uv(env_dir(l)), 0).rgb * u_env_intensity``."""
    uv = equirect_uv(env_dir(l_ws, lighting.rotation))
    return sample_bilinear(lighting.radiance, uv)[..., :3] * lighting.intensity


def surface(gb: dict, v: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Shading normal ``[N, 3]`` and n.v ``[N]`` (as every lighting pass computes them)."""
    n = shading_normal(gb["normal"], v)
    return n, (n * v).sum(-1).clamp(0.0, 1.0)


def env_below(lighting: Lighting) -> float:
    """How bright the environment's light from below is against its light from above: the
    luminance of its irradiance on a surface facing down over that on a surface facing up, in
    [0, 1] (0 for a black sky, 1 for light from below alone). The irradiance is the map's
    (``lighting.irradiance``: row 0 faces +Y, the last row -Y, as ``irradiance_lookup`` reads
    them at n = +-Y) plus each compact light taken out of it (``lighting.lights``: irradiance
    times max(n.l, 0)); a rotation about +Y leaves it unchanged and the intensity cancels. Twin of
    :func:`viewer.environment.irradiance.env_below` (the viewer's ``u_env_below``), which the IBL's
    builders compute in numpy from the array this texture was uploaded from.

    Why a student reads it (``features`` ``"ssao-env"``): split-sum lights a surface facing down
    with the environment's lower hemisphere, which in a scene is mostly the floor; under an indoor
    map or a sky without its sun that light is already too bright, and a learned gain on the
    screen-space bounce then adds to the error, while under a sunlit sky the bounce misses light
    (the students page, "The bounce and the environment's light from below")."""
    irr = lighting.irradiance.to(torch.float64)
    e = torch.stack([irr[0, :, :3].mean(0), irr[-1, :, :3].mean(0)])
    n = torch.tensor([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]], dtype=torch.float64)
    for light in lighting.lights or ((lighting.sun,) if lighting.sun is not None else ()):
        cos = (n @ torch.tensor(light.direction, dtype=torch.float64)).clamp_min(0.0)
        e = e + torch.tensor(light.irradiance, dtype=torch.float64) * cos[:, None]
    lum = e @ torch.tensor(LUMA, dtype=torch.float64)
    if float(lum[0]) <= 0.0:  # a black sky 0; light from below alone 1 (the clamp's end)
        return 1.0 if float(lum[1]) > 0.0 else 0.0
    return float((lum[1] / lum[0]).clamp(0.0, 1.0))


def student_features(gb: dict, v: torch.Tensor, lighting: Lighting, ao: torch.Tensor,
                     vis: torch.Tensor | None = None, dominant: bool = False, sun: bool = False,
                     specular_occlusion: bool = True) -> tuple[torch.Tensor, ...]:
    """Inputs of the student at each pixel, as ``shade_neural.frag`` forms them.

    Returns ``x [N, 12]`` (albedo, roughness, metallic, specular, ao, n.v, dfg.a, dfg.b, vis,
    env_below - :func:`env_below` of ``lighting``, the same at every pixel -:
    :data:`learned.neural.student.ALL_INPUTS`; a student selects its own),
    ``irradiance [N, 3]`` (the irradiance map's, times intensity) and ``prefiltered [N, 3]`` (GGX-prefiltered
    radiance along the mirror direction at the pixel's roughness, times intensity). ``ao [N]`` is
    the occlusion the pass uses, ``vis [N]`` the screen-space visibility of the environment's light
    (the g channel of the SSAO pass with ``SSAO_ENV_VIS``; 1 when None). ``dfg`` is the split-sum
    LUT at (n.v, clamped roughness), zeros when ``lighting`` has no LUT. ``dominant``: read the
    prefiltered radiance along the split-sum model's dominant direction (``split3`` students, as
    ``ggx_split_sum``) instead of the mirror direction.

    ``specular_occlusion``: the prefiltered radiance times
    :func:`~learned.twins.shading.specular_occlusion` of ``ao`` (``SPECULAR_OCCLUSION``, the
    viewer's default ``[render] specular_occlusion``).

    ``sun`` (a student whose base shades the environment's sun, ``shade_neural.frag`` with
    ``SUN_LIGHT``): a fourth tensor ``sun [N, 13]`` (n, v, l world space - lifted above the
    horizon where it cuts the sun, ``disc_light`` -, the sun's irradiance times intensity - times
    the disc's horizon factor -, its specular weight w = ``sun_specular_weight``: the arguments of
    ``neural_student_sun_split``), and where w < 1 the prefiltered radiance mixes in the whole
    environment's chain as the pass does. Without a sun in ``lighting`` (the plain IBL) the
    irradiance is 0: no sun term.
    """
    n, nov = surface(gb, v)
    r = clamp_perceptual_roughness(gb["roughness"][..., 0])
    irradiance = irradiance_lookup(lighting.irradiance, env_dir(n, lighting.rotation)) \
        * lighting.intensity
    reflected = reflect(-v, n)
    if dominant:
        reflected = specular_dominant_direction(
            n, reflected, ibl_dominant_factor(lighting.dominant, nov, r))
    r_env = env_dir(reflected, lighting.rotation)
    sun_light = sun and lighting.sun is not None
    if sun_light:  # the sun's specular share w is analytic, the rest is in the whole chain
        # one weight for every light taken out: the widest's (IBL.bind's u_sun_radius)
        radius = max(float(li.angular_radius) for li in (lighting.lights or (lighting.sun,)))
        w = sun_specular_weight(r * r, torch.full_like(r, radius))
        prefiltered = ibl_specular_radiance_sun(lighting.prefiltered, lighting.prefiltered_full,
                                                r_env, r, lighting.levels, w) * lighting.intensity
    else:
        prefiltered = ibl_specular_radiance(lighting.prefiltered, r_env, r,
                                            lighting.levels) * lighting.intensity
    if specular_occlusion:  # shade_neural.frag SPECULAR_OCCLUSION
        prefiltered = prefiltered * occluded_share(nov, ao, r * r)[..., None]
    if lighting.dfg is not None:
        dfg = ibl_dfg(lighting.dfg, nov, r)
    else:
        dfg = torch.zeros(*nov.shape, 2)
    if vis is None:
        vis = torch.ones_like(nov)
    x = torch.cat([gb["albedo"], gb["roughness"], gb["metallic"], gb["specular"], ao[..., None],
                   nov[..., None], dfg, vis[..., None],
                   torch.full_like(nov, env_below(lighting))[..., None]], dim=-1)
    if not sun:
        return x, irradiance, prefiltered
    if not sun_light:  # no sun taken out: a zero light
        l_ws = torch.tensor([0.0, 1.0, 0.0]).expand_as(n)
        e = torch.zeros_like(n)
        w = torch.ones_like(r)
    else:
        s = lighting.sun
        l_ws = rotate_y(torch.tensor(s.direction, dtype=torch.float32).expand_as(n),
                        torch.full(r.shape, lighting.rotation, dtype=torch.float32))
        e = (torch.tensor(s.irradiance, dtype=torch.float32)
             * torch.tensor(lighting.intensity, dtype=torch.float32)).expand_as(n)
        # the sun as the disc it is, cut by the horizon (shade_neural.frag's disc_light)
        disc = disc_light(n, l_ws, torch.full_like(r, float(s.angular_radius)))
        l_ws, e = disc[..., :3], e * disc[..., 3:]
    return x, irradiance, prefiltered, torch.cat([n, v.expand_as(n), l_ws, e, w[..., None]], -1)


def env_lights_base(gb: dict, x: torch.Tensor, sun_args: torch.Tensor, lighting: Lighting,
                    multiscatter: bool, count: int | None = None) -> torch.Tensor:
    """``[N, 3]``: the environment's compact lights besides its sun (``lighting.lights[1:]``, the
    first ``count``; ENV_LIGHTS) through a sun student's classical base, as shade_neural.frag adds
    them (``env_lights_ggx``, no learned factors): a term the network does not see, added to its
    prediction in training as in the pass. ``x``, ``sun_args``: :func:`student_features`' first
    and fourth tensors (ao is x[:, 6], dfg x[:, 8:10]; n, v, w are in sun_args). Their diffuse
    part is scaled by ao, as ggx_split_sum scales its lights' (and a student its sun's)."""
    from learned.twins.brdf import compute_f0, f90_from_f0
    from learned.twins.shading import diffuse_color, env_lights_ggx

    others = tuple(lighting.lights)[1:]
    others = others[:count] if count is not None else others
    if not others:
        return torch.zeros(x.shape[0], 3)
    metallic = gb["metallic"][:, 0]
    r = clamp_perceptual_roughness(gb["roughness"][:, 0])
    ms = torch.full_like(r, float(bool(multiscatter)))
    f0 = compute_f0(gb["albedo"], metallic, gb["specular"][:, 0])
    return env_lights_ggx(others, diffuse_color(gb["albedo"], metallic) * x[:, 6:7], f0,
                          f90_from_f0(f0), r * r,
                          x[:, 8:10], ms, sun_args[:, 0:3], sun_args[:, 3:6], sun_args[:, 12],
                          lighting.intensity, lighting.rotation)


def sample_lights(n: torch.Tensor, u: torch.Tensor, strategy: str, lighting: Lighting
                  ) -> tuple[torch.Tensor, torch.Tensor]:
    """Directions ``l [..., 3]`` (world) and their solid-angle pdfs ``[...]`` for the uniform pairs
    ``u [..., 2]`` at normals ``n`` (broadcast): ``uniform`` / ``cosine`` hemisphere about n, or
    ``env`` importance sampling of the environment (thesis appendix B.4). pdf 0 = skip."""
    if strategy == "uniform":
        l = tangent_to_world(sample_uniform_hemisphere(u), n.expand(*u.shape[:-1], 3))
        return l, torch.full(u.shape[:-1], 0.5 / math.pi)
    if strategy == "cosine":
        l = tangent_to_world(sample_cosine_hemisphere(u), n.expand(*u.shape[:-1], 3))
        return l, (n * l).sum(-1).clamp_min(0.0) / math.pi
    if strategy == "env":
        e = sample_env(lighting.marginal, lighting.conditional, lighting.pdf, u)
        l = rotate_y(e[..., :3], torch.full(u.shape[:-1], lighting.rotation))
        return l, e[..., 3]
    raise ValueError(f"unknown light sampling strategy {strategy!r} (known: {', '.join(STRATEGIES)})")
