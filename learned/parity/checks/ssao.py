"""The SSAO and indirect-light pass (``passes/ssao.frag``) against :func:`learned.twins.ssao.ssao_pass`."""
from __future__ import annotations

import math

import numpy as np
import torch

from learned.twins.equirect import rotate_y
from learned.twins.ssao import ssao_blur, ssao_pass, ssao_sample_pixel, ssao_upsample
from viewer.passes.ssao import ENV_VIS_RADIUS, ENV_VIS_STEPS
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

from ..results import ParityResult
from . import collector
from .models import PARITY_SCENE, gl_gbuffer, gl_texture


def checks() -> dict:
    """This module's pass checks: name -> (model or None, check(programs) -> results)."""
    found, register_pass_check = collector()


    @register_pass_check("ssao")
    def check_ssao(programs):
        scene = scene_from_dict(PARITY_SCENE).with_render(
            shadows=False, model="ggx_split_sum", ssao=True, indirect=True, ssao_rays=6,
            ssao_steps=8,
            ssao_radius=0.6, ssao_thickness=0.3, seed=3,
            indirect_blur=False)  # the pass's own composite; the blur: ssao:denoise
        renderer = Renderer(ctx=programs.ctx)
        try:
            targets = renderer.draw(scene)
            gb = gl_gbuffer(targets)

            def read(name):
                return gl_texture(getattr(targets, name))

            ao_gl, direct, final_gl = read("ssao"), read("direct"), read("radiance")
            raw_gl = gl_texture(targets.targets["ssao/raw"].texture)  # before the blur
            s = scene.render
            # the occlusion pass again with the environment's visibility (SSAO_ENV_VIS), as a
            # student with "vis" features runs it
            vis_dirs = renderer.resources.power_directions(scene.environment)
            vis_gl = gl_texture(renderer.environment_visibility(scene, targets))
            with torch.no_grad():
                ao = ssao_pass(gb, targets.camera, s.ssao.rays, s.ssao.steps, s.ssao.radius,
                               s.ssao.thickness, s.mc.seed).numpy()
                final = ssao_pass(gb, targets.camera, s.ssao.rays, s.ssao.steps,
                                  s.ssao.radius, s.ssao.thickness, s.mc.seed,
                                  direct=torch.from_numpy(direct)).numpy()
                vis = ssao_pass(gb, targets.camera, s.ssao.rays, s.ssao.steps, s.ssao.radius,
                                s.ssao.thickness, s.mc.seed, vis_dirs=torch.from_numpy(vis_dirs),
                                vis_steps=ENV_VIS_STEPS, vis_radius=ENV_VIS_RADIUS,
                                env_rotation=math.radians(scene.environment.rotation_deg)).numpy()
        finally:
            renderer.release()
        # the visibility's share per direction is max(n.l_k, 0) / sum: a flipped hit moves it by
        # at most 1 (one direction carrying all the light); the robust test bounds the count
        surface = ((gb["alpha"][..., 0] > 0.0) & (gb["depth"][..., 0] > 0.0))[..., None]
        with torch.no_grad():
            blurred = torch.where(surface, ssao_blur(torch.from_numpy(raw_gl), gb,
                                                     targets.camera), torch.ones(4)).numpy()
        ray = 1.0 / s.ssao.rays
        return [robust_compare("ssao:occlusion", raw_gl, ao, ray),
                upsample_compare("ssao:blur", ao_gl, blurred),
                robust_compare("ssao:env_visibility", vis_gl, vis,
                               visibility_steps(gb, vis_dirs, scene, ray)),
                robust_compare("ssao:indirect", final_gl, final,
                               indirect_steps(gb, direct, targets.camera, s.ssao))]

    @register_pass_check("ssao:scale")
    def check_ssao_scale(programs):
        """SSAO at reduced scale (3: odd, and not a divisor of the parity frame's size, so the
        last texels' sample pixels are clamped): the low-resolution occlusion, visibility and
        gather passes, the upsampling pass on the GL low-resolution target (the filter alone),
        and the whole indirect light."""
        k = 3
        scene = scene_from_dict(PARITY_SCENE).with_render(
            shadows=False, model="ggx_split_sum", ssao=True, indirect=True, ssao_rays=6,
            ssao_steps=8,
            ssao_radius=0.6, ssao_thickness=0.3, seed=3, ssao_scale=k)
        renderer = Renderer(ctx=programs.ctx)
        try:
            targets = renderer.draw(scene)
            gb = gl_gbuffer(targets)
            low_gl = gl_texture(targets.targets[f"ssao/{k}"].texture)
            gathered_gl = gl_texture(targets.targets[f"gathered/{k}"].texture)
            full_gl = gl_texture(targets.targets["ssao/raw"].texture)  # upsampled, not blurred
            direct = gl_texture(targets.direct)
            final_gl = gl_texture(targets.radiance)
            vis_dirs = renderer.resources.power_directions(scene.environment)
            vis_full_gl = gl_texture(renderer.environment_visibility(scene, targets))
            # the visibility pass's own low-resolution target (its graph's scope)
            vis_low_gl = gl_texture(renderer.resources.pool.kept("visibility",
                                                                 f"ssao/{k}").texture)
            s = scene.render
            args = (gb, targets.camera, s.ssao.rays, s.ssao.steps, s.ssao.radius,
                    s.ssao.thickness, s.mc.seed)
            surface = ((gb["alpha"][..., 0] > 0.0) & (gb["depth"][..., 0] > 0.0))[..., None]
            with torch.no_grad():
                low = ssao_pass(*args, scale=k).numpy()
                vis_low = ssao_pass(*args, vis_dirs=torch.from_numpy(vis_dirs),
                                    vis_steps=ENV_VIS_STEPS, vis_radius=ENV_VIS_RADIUS,
                                    env_rotation=math.radians(scene.environment.rotation_deg),
                                    scale=k).numpy()
                up = torch.where(surface, ssao_upsample(torch.from_numpy(low_gl), gb,
                                                        targets.camera, k, 1.0),
                                 torch.ones(4)).numpy()
                vis_up = torch.where(surface, ssao_upsample(torch.from_numpy(vis_low_gl), gb,
                                                            targets.camera, k, 1.0),
                                     torch.ones(4)).numpy()
                gathered = ssao_pass(*args, direct=torch.from_numpy(direct), scale=k,
                                     gather=True).numpy()
                final = ssao_pass(*args, direct=torch.from_numpy(direct), scale=k).numpy()
        finally:
            renderer.release()
        ray = 1.0 / s.ssao.rays
        return [robust_compare("ssao:scale:occlusion", low_gl, low, ray),
                robust_compare("ssao:scale:env_visibility", vis_low_gl, vis_low,
                               visibility_steps(gb, vis_dirs, scene, ray, k)),
                upsample_compare("ssao:scale:upsample", full_gl, up),
                upsample_compare("ssao:scale:upsample_visibility", vis_full_gl, vis_up),
                robust_compare("ssao:scale:gather", gathered_gl, gathered,
                               gather_steps(gb, direct, targets.camera, s.ssao, k)),
                robust_compare("ssao:scale:indirect", final_gl, final,
                               indirect_steps(gb, direct, targets.camera, s.ssao, pad=2 * k))]

    @register_pass_check("ssao:denoise")
    def check_ssao_denoise(programs):
        """The denoised indirect light at scale 1 (``indirect_blur``): the gather at full
        resolution, the bilateral blur on the GL gather (the filter alone) and the whole indirect
        light (the blur spreads a flipped ray's step over its 5 x 5 footprint: ``pad`` 2)."""
        scene = scene_from_dict(PARITY_SCENE).with_render(
            shadows=False, model="ggx_split_sum", ssao=True, indirect=True, ssao_rays=6,
            ssao_steps=8, ssao_radius=0.6, ssao_thickness=0.3, seed=3,
            indirect_blur=True)
        renderer = Renderer(ctx=programs.ctx)
        try:
            targets = renderer.draw(scene)
            gb = gl_gbuffer(targets)
            gathered_gl = gl_texture(targets.targets["gathered/1"].texture)
            blurred_gl = gl_texture(targets.targets["gathered/blur"].texture)
            direct, final_gl = gl_texture(targets.direct), gl_texture(targets.radiance)
            s = scene.render
            args = (gb, targets.camera, s.ssao.rays, s.ssao.steps, s.ssao.radius,
                    s.ssao.thickness, s.mc.seed)
            surface = ((gb["alpha"][..., 0] > 0.0) & (gb["depth"][..., 0] > 0.0))[..., None]
            with torch.no_grad():
                gathered = ssao_pass(*args, direct=torch.from_numpy(direct), gather=True).numpy()
                blurred = torch.where(surface, ssao_blur(torch.from_numpy(gathered_gl), gb,
                                                         targets.camera),
                                      torch.ones(4)).numpy()
                final = ssao_pass(*args, direct=torch.from_numpy(direct), denoise=True).numpy()
        finally:
            renderer.release()
        rel = float(np.abs(blurred_gl - blurred).max() / max(np.abs(blurred).max(), 1e-6))
        return [robust_compare("ssao:denoise:gather", gathered_gl, gathered,
                               gather_steps(gb, direct, targets.camera, s.ssao, 1)),
                ParityResult("ssao:denoise:blur", float(np.abs(blurred_gl - blurred).max()), rel,
                             "rel 2e-5", rel <= 2e-5, "pass", "the blur of ssao:blur on E",
                             "a normalised weighted mean: its error is the weights' relative "
                             "error (ssao:blur's bound, 2e-5) times the values' spread"),
                robust_compare("ssao:denoise:indirect", final_gl, final,
                               indirect_steps(gb, direct, targets.camera, s.ssao, pad=2))]

    return found


def upsample_compare(name, gl, ref):
    """The joint bilateral upsampling (or the bilateral blur) on the same input: a normalised
    weighted mean of values in [0, 1], so its error is the weights' relative error times the
    spread."""
    diff = np.abs(gl - ref).max(axis=-1)
    atol = 2e-5
    ok = float(diff.max()) <= atol
    return ParityResult(name, float(diff.max()), float(diff.max()), f"atol {atol:g}", ok,
                        "pass", "max abs 2.4e-7 on llvmpipe",
                        "each weight: the plane term 1 - 50 |(p - q).n_q| / z_p cancels "
                        "(p, q ~ 5 units: a few ulp, 1e-6 abs, x 50 / z_p -> 2e-5 relative "
                        "at worst), cos^8 ~ 8 ulp; the mean of values in [0, 1] moves by the "
                        "weights' relative error: <= 2e-5")


def reach_max(gb, direct, camera, radius: float, pixels=None, pad: int = 0) -> np.ndarray:
    """[..., 3]: per marching pixel (``pixels`` [..., 2] x, y; default every pixel), the
    brightest direct light per channel of a surface pixel a ray can hit: the march's points lie
    within ``radius`` of the pixel's view-space position, so its hits in the screen-space box of
    that ball (widened by ``pad`` pixels; the whole frame where the ball reaches the camera)."""
    alpha = gb["alpha"][..., 0].numpy()
    depth = gb["depth"][..., 0].numpy().astype(np.float64)
    h, w = alpha.shape
    light = np.where((alpha > 0.0)[..., None], np.abs(direct[..., :3]), 0.0)
    if pixels is None:
        ys, xs = np.mgrid[0:h, 0:w]
        pixels = np.stack([xs, ys], -1)
    tan = np.asarray(camera.tan_half_fov(), np.float64)
    res = np.array([w, h], np.float64)
    px, py = pixels[..., 0], pixels[..., 1]
    z = depth[py, px][..., None]
    marches = (alpha[py, px] > 0.0) & (z[..., 0] > 0.0)
    centre = ((pixels + 0.5) / res * 2.0 - 1.0) * tan * z  # view-space x, y
    near = np.maximum(z - radius, 1e-6)
    corners = np.stack([(centre + sc * radius) / zc for sc in (-1, 1)
                        for zc in (near, z + radius)])  # x / depth, y / depth at the box corners
    lo = np.floor((corners.min(0) / tan + 1.0) / 2.0 * res).astype(int) - 1 - pad
    hi = np.floor((corners.max(0) / tan + 1.0) / 2.0 * res).astype(int) + 1 + pad
    whole = (z[..., 0] - radius <= 1e-6)[..., None]  # the ball reaches the camera
    lo = np.where(whole, 0, np.maximum(lo, 0))
    hi = np.where(whole, [w - 1, h - 1], np.minimum(hi, [w - 1, h - 1]))
    out = np.zeros(pixels.shape[:-1] + (3,))
    for idx in zip(*np.nonzero(marches)):
        (x0, y0), (x1, y1) = lo[idx], hi[idx]
        out[idx] = light[y0:y1 + 1, x0:x1 + 1].reshape(-1, 3).max(0)
    return out


def indirect_steps(gb, direct, camera, ssao, pad: int = 0) -> np.ndarray:
    """[H, W, 4]: what one flipped ray may change in the composite direct + (1 - m) a E alpha:
    E (the mean over rays of the hit pixels' direct light) by one ray's share of the brightest
    direct light it can reach (gained, lost or moved to another hit: direct >= 0); the alpha
    channel not at all. (The upsampled E of a reduced scale k is a normalised weighted mean of
    texels marching from pixels within 2k: ``pad``.)"""
    share = ((1.0 - gb["metallic"].clamp(0.0, 1.0)) * gb["albedo"] * gb["alpha"]).numpy()
    step = share * reach_max(gb, direct, camera, ssao.radius, pad=pad) / ssao.rays
    return np.concatenate([step, np.zeros(step.shape[:-1] + (1,))], axis=-1)


def gather_steps(gb, direct, camera, ssao, scale: int) -> np.ndarray:
    """[h, w, 4] of a reduced-scale gathered light (E, 1): one ray's share of the brightest
    direct light the texel's rays can reach, per channel; the coverage channel not at all."""
    h, w = gb["alpha"].shape[:2]
    ty, tx = torch.meshgrid(torch.arange(-(-h // scale)), torch.arange(-(-w // scale)),
                            indexing="ij")
    q = ssao_sample_pixel(torch.stack([tx, ty], dim=-1), scale, (w, h)).numpy()
    step = reach_max(gb, direct, camera, ssao.radius, pixels=q) / ssao.rays
    return np.concatenate([step, np.zeros(step.shape[:-1] + (1,))], axis=-1)


def visibility_steps(gb, vis_dirs, scene, ray: float, scale: int = 1) -> np.ndarray:
    """[h, w, 4] for the occlusion pass with the environment's visibility: O(x) in r, b, a (one
    ray's share) and S(x) = sum_k V_k c_k / sum_k c_k, c_k = max(n.l_k, 0), in g, which one flipped
    march towards direction k moves by c_k / sum c: the largest such share at the pixel the
    texel marches from (each direction marches with its own jitter, so a repeated direction is
    still one share per flip)."""
    n = gb["normal"]
    n = n / n.norm(dim=-1, keepdim=True).clamp_min(1e-30)
    if scale > 1:
        h, w = n.shape[:2]
        ty, tx = torch.meshgrid(torch.arange(-(-h // scale)), torch.arange(-(-w // scale)),
                                indexing="ij")
        q = ssao_sample_pixel(torch.stack([tx, ty], dim=-1), scale, (w, h))
        n = n[q[..., 1], q[..., 0]]
    angle = torch.tensor(math.radians(scene.environment.rotation_deg))
    l_ws = rotate_y(torch.from_numpy(np.asarray(vis_dirs, np.float32)), angle)  # [K, 3]
    c = (n[..., None, :] * l_ws).sum(-1).clamp_min(0.0)  # [h, w, K]
    total = c.sum(-1)
    share = torch.where(total > 0.0, c.max(-1).values / total.clamp_min(1e-30),
                        torch.zeros_like(total)).numpy()
    step = np.full(share.shape + (4,), ray)
    step[..., 1] = share
    return step


def robust_compare(name, gl, ref, step):
    # A hit test is a threshold: float32 rounding may flip one ray's step in rare pixels.
    # Pass: >= 99% of pixels within 1e-5 (abs + rel), none off by more than one ray's share
    # (``step``: a number, or per pixel and channel). Measured on llvmpipe: every pixel of every
    # result within 1e-5 (max 4.8e-7).
    diff_c = np.abs(gl - ref)
    diff = diff_c.max(axis=-1)
    close = diff <= 1e-5 + 1e-5 * np.abs(ref).max(axis=-1)
    frac = float(close.mean())
    ok = frac >= 0.99 and bool((diff_c <= np.broadcast_to(step, diff_c.shape) + 1e-5).all())
    rel = float((diff / np.maximum(np.abs(ref).max(axis=-1), 1e-6)).max())
    return ParityResult(name, float(diff.max()), rel,
                        f"99% of pixels within 1e-5, rest within one ray ({frac:.2%} close)",
                        ok, "pass", "100% of pixels exact to 1e-5 on llvmpipe",
                        "not a rounding bound: the march's hit tests are thresholds, so "
                        "float32 differences (view_to_frag, surface_depth_at envelopes) "
                        "flip whole rays in rare pixels; elsewhere both sides take the same "
                        "hits and agree to ~1e-6")
