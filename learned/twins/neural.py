"""Twins of ``shaders/lib/neural.glsl`` and the parity checks of the neural shading models.

Function twins are compared element-wise like every library function. Three pass checks cover
the generated network code and the two lighting passes, all on the shipped weights
(``assets/weights``) unless a caller passes its own file:

* ``neural:network``   the generated ``neural_student_weights`` in a compute kernel vs
  ``Student.weights`` on 4096 random inputs (outputs in [0, 1]; the issue's float32 bound is
  1e-4 abs; measured on llvmpipe 1.0e-7, shipped 8-16-16-3 "pbr3" student; 1.2e-7 the 10-16-16-6
  "dfg" free6 student shipped before). Registered for every weight storage
  (``viewer.neural.WEIGHT_STORAGES``: ``neural:network``, ``neural:network:ubo``,
  ``neural:network:texture``; the same 1.0e-7 for each).
* ``model:neural``     render, read the G-buffer back, shade in torch, compare radiance (also
  with ``neural_storage`` ``ubo`` and ``texture``).
* ``model:neural_teacher``  the same for the teacher pass with 8 samples of ``env`` and ``uniform``
  sampling (the torch twin draws the same scrambled Sobol' samples, lib/mc.glsl), and for a random
  teacher of the other input form than the shipped one (architecture ``"light_input"``: with or
  without the log(1 + L_in) inputs), so both forms of the generated
  ``neural_teacher_contribution`` are compared whichever is shipped.
"""
from __future__ import annotations

import torch

from learned.neural.torch_lighting import (STRATEGIES, env_lights_base, env_radiance,
                                     student_features, surface)
from learned.twins.deferred import emitted_radiance, env_dir, reflect, view_ray_ws
from learned.twins.mc import mc_sample_2d

from .brdf import clamp_perceptual_roughness, d_ggx, v_smith_ggx_correlated
from .equirect import equirect_uv
from .ibl import (DIRECTION_ABS_ERROR, equirect_uv_error, ibl_specular_dfg, prefilter_lod,
                  sample_trilinear_envelope)

from .common import INV_PI, half_vector, saturate

NEURAL_OUTPUT_SCALE = 2.0  # GLSL NEURAL_OUTPUT_SCALE (lib/neural.glsl)


def fourier_feature(x: torch.Tensor, freq: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec2 fourier_feature(float x, float freq)``: ``[...]`` -> ``[..., 2]``."""
    a = freq * x
    return torch.stack([torch.sin(a), torch.cos(a)], dim=-1)


def relu4(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 relu4(vec4 x)``."""
    return x.clamp_min(0.0)


def sigmoid4(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 sigmoid4(vec4 x)`` = 1 / (1 + e^-x)."""
    return 1.0 / (1.0 + torch.exp(-x))


def softplus4(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 softplus4(vec4 x)`` = max(x, 0) + log1p(e^-|x|), with log1p evaluated by the
    same Goldberg formula as the GLSL (float32 log1p differs between libraries)."""
    y = torch.exp(-x.abs())
    u = 1.0 + y
    d = u - 1.0
    l1p = torch.where(d == 0.0, y, torch.log(u) * y / d.clamp_min(1e-30))
    return x.clamp_min(0.0) + l1p


def neural_student_radiance(k_diffuse: torch.Tensor, k_specular: torch.Tensor,
                            albedo: torch.Tensor, irradiance: torch.Tensor,
                            prefiltered: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 neural_student_radiance(...)`` (output form ``free6``): every argument
    ``[..., 3]``; S k_diffuse albedo E / pi + S k_specular P."""
    return (NEURAL_OUTPUT_SCALE * k_diffuse * albedo * irradiance * INV_PI
            + NEURAL_OUTPUT_SCALE * k_specular * prefiltered)


def neural_student_radiance_pbr(k: torch.Tensor, diffuse: torch.Tensor, f0: torch.Tensor,
                                f90: torch.Tensor, irradiance: torch.Tensor,
                                prefiltered: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 neural_student_radiance_pbr(...)`` (output form ``pbr3``): ``k`` = (k_d, k_a,
    k_b) ``[..., 3]``, diffuse, f0, irradiance, prefiltered ``[..., 3]``, f90 ``[...]``;
    S k_d diffuse E / pi + S (k_a f0 + k_b f90) P."""
    s = NEURAL_OUTPUT_SCALE * k
    spec = s[..., 1:2] * f0 + (s[..., 2] * f90)[..., None]
    return s[..., 0:1] * diffuse * irradiance * INV_PI + spec * prefiltered


def neural_student_radiance_split(k: torch.Tensor, diffuse: torch.Tensor, f0: torch.Tensor,
                                  f90: torch.Tensor, dfg: torch.Tensor, irradiance: torch.Tensor,
                                  prefiltered: torch.Tensor, spec_scale: torch.Tensor
                                  ) -> torch.Tensor:
    """GLSL ``vec3 neural_student_radiance_split(...)`` (output form ``split3``): ``k`` = (k_d,
    k_a, k_b) ``[..., 3]``, dfg ``[..., 2]``, f90 ``[...]``, spec_scale ``[..., 3]`` (the
    multiple-scattering compensation of a student with ``"multiscatter": true``, else 1); the
    split-sum model with learned corrections S k (k = 0.5: ``ggx_split_sum``, multiscatter as
    spec_scale says)."""
    s = NEURAL_OUTPUT_SCALE * k
    e_spec = ibl_specular_dfg(dfg, f0, f90) * spec_scale
    spec = (s[..., 1:2] * f0 * (dfg[..., 1:2] - dfg[..., 0:1])
            + (s[..., 2] * f90 * dfg[..., 0])[..., None]) * spec_scale
    return s[..., 0:1] * diffuse * irradiance * INV_PI * (1.0 - e_spec).clamp_min(0.0) \
        + spec * prefiltered


def neural_student_sun_split(k: torch.Tensor, diffuse: torch.Tensor, f0: torch.Tensor,
                             f90: torch.Tensor, dfg: torch.Tensor, a: torch.Tensor,
                             n: torch.Tensor, v: torch.Tensor, l: torch.Tensor,
                             irradiance: torch.Tensor, specular_weight: torch.Tensor,
                             spec_scale: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 neural_student_sun_split(...)``: the environment's sun under a ``split3`` student
    whose base shades it (architecture ``"sun": true``): ``k`` ``[..., 3]``, diffuse, f0, n, v, l,
    irradiance, spec_scale m ``[..., 3]``, f90, a, specular_weight ``[...]``, dfg ``[..., 2]`` ->
    ``[..., 3]``; [S k_d diffuse / pi (1 - e_spec m) + (S k_a f0 (1 - Fc) + S k_b f90 Fc) D V m w]
    E (n.l), 0 where n.l <= 0 (k = 0.5: ``ggx_environment_sun``, multiscatter as m says)."""
    NoL = (n * l).sum(-1)
    s = NEURAL_OUTPUT_SCALE * k
    h = half_vector(v, l)
    NoV = saturate((n * v).sum(-1))
    NoH = saturate((n * h).sum(-1))
    VoH = saturate((v * h).sum(-1))
    e_spec = ibl_specular_dfg(dfg, f0, f90) * spec_scale
    fd = s[..., 0:1] * diffuse * INV_PI * (1.0 - e_spec).clamp_min(0.0)
    x = 1.0 - VoH
    x2 = x * x
    fc = (x2 * x2 * x)[..., None]
    sf0 = s[..., 1:2] * f0
    fresnel = sf0 + ((s[..., 2] * f90)[..., None] - sf0) * fc
    fs = (d_ggx(NoH, a) * v_smith_ggx_correlated(NoV, NoL, a))[..., None] * fresnel * spec_scale
    out = (fd + fs * specular_weight[..., None]) * irradiance * NoL[..., None]
    return torch.where((NoL > 0.0)[..., None], out, torch.zeros_like(out))


def neural_indirect_factor(k: torch.Tensor) -> torch.Tensor:
    """GLSL ``float neural_indirect_factor(float k)``: S k, the factor on the screen-space
    indirect light of a student with architecture ``"indirect": "factor"``."""
    return NEURAL_OUTPUT_SCALE * k


# ---------------------------------------------------------------------------------------------
# pass checks
# ---------------------------------------------------------------------------------------------


def shade_neural(model: str, net_model, gb: dict, camera, lighting, defines: dict,
                 sample_range: tuple[int, int] = (0, 1), seed: int = 0,
                 envelope: dict | None = None, ssao: torch.Tensor | None = None,
                 outputs: dict | None = None) -> torch.Tensor:
    """Torch twin of ``shade_neural.frag`` / ``shade_neural_teacher.frag`` on a G-buffer read back
    from GL (channel -> ``[H, W, C]``, GL row order). Returns ``[H, W, 4]``. ``ssao``: the SSAO
    pass's output ``[H, W, 4]`` when ``USE_SSAO`` (r: occlusion; g: the environment's visibility,
    read by students with ``vis`` features).

    ``envelope`` (a dict, filled in; the student only): ``"bound"`` ``[H, W, 3]``, how far a
    conforming GPU may land from this result through its texture lookups - the background, the
    prefiltered radiance and the DFG inputs, each lookup's
    :func:`~learned.twins.ibl.sample_trilinear_envelope` (``envelope["weight_bits"]``) times
    |d radiance / d lookup| through the network by autograd.

    ``outputs`` (a dict, filled in): ``"indirect_factor"`` ``[H, W]``, the pass's second output
    ``o_indirect_factor`` for a student with a learned indirect factor (1 on the background)."""
    h, w = gb["alpha"].shape[:2]
    ys, xs = torch.meshgrid(torch.arange(h, dtype=torch.float32) + 0.5,
                            torch.arange(w, dtype=torch.float32) + 0.5, indexing="ij")
    basis = torch.tensor(camera.basis(), dtype=torch.float32)
    d = view_ray_ws(torch.stack([xs, ys], -1), basis.T,
                    torch.tensor(camera.tan_half_fov(), dtype=torch.float32),
                    torch.tensor([float(w), float(h)])).reshape(-1, 3)
    if defines.get("BACKGROUND_ENVIRONMENT", 1):
        background = env_radiance(lighting, d)
    else:
        background = torch.zeros_like(d)
    flat = {k: t.reshape(h * w, -1) for k, t in gb.items()}
    v = -d
    tracing = envelope is not None and model == "neural"
    if tracing:
        background = background.detach().requires_grad_(True)
    if model == "neural":
        ao = flat["ao"][:, 0] if defines.get("USE_AO", 1) else torch.ones(h * w)
        vis = None
        if defines.get("USE_SSAO", 0):  # deferred.glsl ambient_occlusion(); shade_neural.frag
            ao = ao * ssao[..., 0].reshape(-1)
            if getattr(net_model, "reads_visibility", False):
                vis = ssao[..., 1].reshape(-1)
        # SUN_LIGHT (a student whose base shades the sun): lighting is the IBL without it
        sun = bool(defines.get("SUN_LIGHT", 0))
        x, irr, pre, *sun_args = student_features(
            flat, v, lighting, ao, vis, dominant=getattr(net_model, "dominant", False), sun=sun,
            specular_occlusion=bool(defines.get("SPECULAR_OCCLUSION", 0)))
        if tracing:
            x, pre = x.detach().requires_grad_(True), pre.detach().requires_grad_(True)
        c = net_model(x, irr, pre, None, *sun_args)
        if sun and defines.get("ENV_LIGHTS", 0):  # the other compact lights: the classical base
            c = c + env_lights_base(flat, x, sun_args[0], lighting,
                                    getattr(net_model, "multiscatter", False),
                                    int(defines["ENV_LIGHTS"]))
        if outputs is not None and getattr(net_model, "learns_indirect", False):
            with torch.no_grad():
                f = net_model.indirect_factor(x.detach())
            covered = flat["alpha"][:, 0] > 0.0
            outputs["indirect_factor"] = torch.where(covered, f, torch.ones_like(f)).reshape(h, w)
    else:
        start, count = sample_range
        px = xs.reshape(-1).floor().to(torch.int64)[:, None]
        py = ys.reshape(-1).floor().to(torch.int64)[:, None]
        idx = torch.arange(start, start + count, dtype=torch.int64)[None, :]
        u = mc_sample_2d(px, py, idx, seed, 0)  # [N, S, 2]
        strategy = {v_: k for k, v_ in STRATEGIES.items()}[defines["SAMPLING"]]
        c = net_model(flat, v, lighting, u, strategy)
    c = c + emitted_radiance(flat)  # write_radiance(c + emitted_radiance(g), ...)
    alpha = flat["alpha"][:, 0]
    covered = (alpha > 0.0)[:, None]
    out = torch.where(covered, background + (c - background) * alpha[:, None], background)
    if tracing:
        envelope["bound"] = _student_envelope(out, background, x, pre, flat, d, v, lighting,
                                              envelope.get("weight_bits", 8)).reshape(h, w, 3)
        out = out.detach()
    return torch.cat([out, alpha[:, None]], -1).reshape(h, w, 4)


def _student_envelope(out, background, x, pre, flat, d, v, lighting, bits: int) -> torch.Tensor:
    """|d out / d lookup| x lookup envelope, summed over the student pass's filtered lookups."""
    grads = torch.autograd.grad(out.sum(), [background, x, pre], allow_unused=True)
    g_bg, g_x, g_pre = (torch.zeros_like(t) if g is None else g.abs()
                        for g, t in zip(grads, (background, x, pre)))
    with torch.no_grad():
        d_env = env_dir(d, lighting.rotation)
        bound = g_bg * sample_trilinear_envelope(
            [lighting.radiance], equirect_uv(d_env), torch.zeros(d.shape[:-1]),
            equirect_uv_error(d_env), weight_bits=bits)[..., :3] * lighting.intensity
        n, nov = surface(flat, v)
        r = clamp_perceptual_roughness(flat["roughness"][..., 0])
        r_env = env_dir(reflect(-v, n), lighting.rotation)
        lod = prefilter_lod(r, torch.full_like(r, float(lighting.levels)))
        chains = [lighting.prefiltered]
        if lighting.prefiltered_full is not None:  # SUN_LIGHT: mixed with the whole chain
            chains.append(lighting.prefiltered_full)
        e_pre = torch.stack([sample_trilinear_envelope(
            chain, equirect_uv(r_env), lod, equirect_uv_error(r_env, 2.0 * DIRECTION_ABS_ERROR),
            weight_bits=bits)[..., :3] for chain in chains]).amax(0)  # a convex mix: <= the max
        bound = bound + g_pre * e_pre * lighting.intensity
        if lighting.dfg is not None:  # inputs 8, 9 of x: the DFG lookup
            lut = lighting.dfg
            size = torch.tensor([float(lut.shape[1]), float(lut.shape[0])])
            uv = (torch.stack([nov, r.clamp(0.0, 1.0)], -1) * (size - 1.0) + 0.5) / size
            e = sample_trilinear_envelope([lut], uv, torch.zeros_like(r),
                                          torch.full_like(uv, 1e-6), repeat_u=False,
                                          weight_bits=bits)[..., :2]
            bound = bound + (g_x[:, 8:10] * e).sum(-1, keepdim=True)
    return bound
