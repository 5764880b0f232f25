"""Decompose baked-colour splats into per-splat materials and a cubemap light (thesis sec. 6.4.3-4).

Given a plain 3DGS cloud (SH colour only), render V views of its baked colour with the twin
rasterizer (the supervision I_gt), then optimise per-splat albedo, roughness, metallic (eq. 6.11,
here free per-splat parameters instead of a network head) and a 6-face cubemap light L_cube
(eq. 6.12, free texels) so that the deferred rendering of the rasterised material maps under the
light matches I_gt, with the loss of eq. 6.24:

    L_d = L1(I_render, I_gt) + lambda_M TV(material maps) + lambda_E TV(light faces)   (6.25-6.27)

(L1 and TV are means rather than sums, so the weights do not depend on image size.) Geometry
(positions, covariances, opacities, normals) is fixed, so each view's compositing weights
T_i alpha_i are computed once (:func:`learned.splats.rasterize.weight_matrix`) and a render is a
sparse matrix product - differentiable in the materials and light.

Deferred shading model (:func:`shade`, image-based, direct light only): Lambert diffuse
(1 - m) a / pi * E(n) with the irradiance E integrated over the cubemap texels, plus a split-sum
specular: the cubemap averaged under a spherical-Gaussian lobe around the reflection direction
(sharpness 2 / alpha^2, alpha = r^2) times Karis' analytic DFG fit, f0 = 0.04 (1 - m) + a m.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from viewer.errors import InputError
from viewer.imageio import write_exr
from viewer.scene.camera import Camera
from viewer.splats.data import Splats, make_splats, sh_basis_3dgs
from viewer.splats.generate import (
    cube_directions,
    cube_solid_angles,
    sky_cubemap,
    sphere_splats,
)
from viewer.splats.ply import read_ply, write_ply

from .rasterize import rasterize, splat_tensors, weight_matrix


@dataclass(frozen=True)
class DecomposeOptions:
    views: int = 8  # cameras on two rings around the cloud
    size: int = 64  # square view resolution
    iterations: int = 300
    lr: float = 0.05
    light_res: int = 8  # cubemap face resolution
    lambda_mat: float = 0.02  # eq. 6.24 lambda_M
    lambda_light: float = 0.01  # eq. 6.24 lambda_E
    fov_y: float = 40.0
    distance: float | None = None  # camera distance (default: from the cloud's extent)
    checkpoint: str | None = None  # path of the checkpoint file (written every checkpoint_every)
    checkpoint_every: int = 50
    resume: bool = True  # continue from ``checkpoint`` if it exists
    seed: int = 0
    progress: bool = True  # tqdm bar


@dataclass
class DecomposeResult:
    splats: Splats  # the input geometry with estimated albedo, roughness, metallic
    light: np.ndarray  # [6, R, R, 3] estimated cubemap radiance
    losses: list[float] = field(default_factory=list)  # per iteration
    psnr: float = float("nan")  # re-render PSNR (dB) over the training views
    iterations: int = 0


# ---- shading ------------------------------------------------------------------------------------

def _cube(res: int) -> tuple[torch.Tensor, torch.Tensor]:
    return (torch.from_numpy(cube_directions(res).reshape(-1, 3)).float(),
            torch.from_numpy(cube_solid_angles(res).reshape(-1)).float())


def env_brdf_approx(f0: torch.Tensor, roughness: torch.Tensor, nov: torch.Tensor) -> torch.Tensor:
    """Karis 2014, "Physically Based Shading on Mobile": analytic fit of the split-sum DFG term.
    f0 [..., 3], roughness [...], nov [...] -> [..., 3]."""
    r4 = roughness[..., None] * torch.tensor([-1.0, -0.0275, -0.572, 0.022]) \
        + torch.tensor([1.0, 0.0425, 1.04, -0.04])
    a004 = torch.minimum(r4[..., 0] ** 2, torch.exp2(-9.28 * nov)) * r4[..., 0] + r4[..., 1]
    a = a004 * -1.04 + r4[..., 2]
    b = a004 * 1.04 + r4[..., 3]
    return f0 * a[..., None] + b[..., None]


def shade(albedo: torch.Tensor, normal: torch.Tensor, roughness: torch.Tensor,
          metallic: torch.Tensor, v: torch.Tensor, light: torch.Tensor) -> torch.Tensor:
    """Outgoing radiance [..., 3] under the cubemap ``light`` [6, R, R, 3]. albedo, normal
    (unit, world), v (unit, towards the eye) [..., 3]; roughness, metallic [...]."""
    dirs, dw = _cube(light.shape[1])
    lt = light.reshape(-1, 3)
    cos = (normal @ dirs.T).clamp_min(0.0)  # [..., T]
    irradiance = (cos * dw) @ lt
    nov = (normal * v).sum(-1).clamp(1e-4, 1.0)
    r = 2.0 * nov[..., None] * normal - v  # reflect(-v, n)
    a = roughness.clamp(0.045, 1.0) ** 2
    sharp = (2.0 / (a * a)).clamp(max=4000.0)
    lobe = torch.exp(sharp[..., None] * ((r @ dirs.T) - 1.0)) * dw  # [..., T]
    prefiltered = (lobe @ lt) / lobe.sum(-1, keepdim=True).clamp_min(1e-12)
    m = metallic[..., None]
    f0 = 0.04 * (1.0 - m) + albedo * m
    return (1.0 - m) * albedo / math.pi * irradiance + prefiltered * env_brdf_approx(
        f0, roughness, nov)


# ---- views ------------------------------------------------------------------------------------

def orbit_cameras(splats: Splats, views: int, size: int, fov_y: float,
                  distance: float | None = None) -> list[Camera]:
    """``views`` cameras on two rings (elevation +25 and -10 degrees) around the cloud centre."""
    centre = np.median(splats.means, axis=0) if len(splats) else np.zeros(3)
    extent = float(np.percentile(np.linalg.norm(splats.means - centre, axis=1), 98)) \
        if len(splats) else 1.0
    dist = distance or 1.25 * extent / math.tan(math.radians(fov_y) / 2)
    cams = []
    for i in range(views):
        az = 2 * math.pi * i / views
        el = math.radians(25.0 if i % 2 == 0 else -10.0)
        p = centre + dist * np.array([math.cos(el) * math.sin(az), math.sin(el),
                                      math.cos(el) * math.cos(az)])
        cams.append(Camera(position=tuple(p), target=tuple(centre), fov_y=fov_y,
                           size=(size, size), near=0.05 * dist, far=10 * dist))
    return cams


@dataclass
class _View:
    camera: Camera
    weights: torch.Tensor  # sparse [P, N]
    coverage: torch.Tensor  # [P]
    normal: torch.Tensor  # [P, 3]
    v: torch.Tensor  # [P, 3] towards the eye
    target: torch.Tensor  # [P, 3] premultiplied baked colour (I_gt)


def _prepare_views(splats: Splats, cameras: list[Camera]) -> list[_View]:
    t = splat_tensors(splats)
    out = []
    with torch.no_grad():
        for cam in cameras:
            g = rasterize(t, cam)
            wm = weight_matrix(t, cam)
            p = cam.width * cam.height
            out.append(_View(cam, wm, g["alpha"].reshape(p), g["normal"].reshape(p, 3),
                             -torch.from_numpy(cam.view_rays_ws().reshape(p, 3)),
                             g["color"].reshape(p, 3)))
    return out


def render_view(view: _View, albedo, roughness, metallic, light) -> tuple[torch.Tensor, dict]:
    """Premultiplied radiance [P, 3] and the material maps (dict of [P, C]) of one view."""
    cov = view.coverage
    safe = torch.where(cov > 0, cov, torch.ones_like(cov))[:, None]
    attrs = torch.cat([albedo, roughness[:, None], metallic[:, None]], -1)
    maps = torch.sparse.mm(view.weights, attrs) / safe
    radiance = shade(maps[:, :3], view.normal, maps[:, 3], maps[:, 4], view.v, light)
    return radiance * cov[:, None], {"albedo": maps[:, :3], "roughness": maps[:, 3:4],
                                     "metallic": maps[:, 4:5]}


def tv(image: torch.Tensor) -> torch.Tensor:
    """Eqs. 6.26/6.27 (as a mean): |M(x+1, y) - M(x, y)| + |M(x, y+1) - M(x, y)|, image [..., H, W, C]."""
    return ((image[..., 1:, :, :] - image[..., :-1, :, :]).abs().mean()
            + (image[..., :, 1:, :] - image[..., :, :-1, :]).abs().mean())


def psnr(a: torch.Tensor, b: torch.Tensor, peak: float = 1.0) -> float:
    mse = float(((a - b) ** 2).mean())
    return float("inf") if mse == 0 else 10.0 * math.log10(peak * peak / mse)


# ---- optimisation ---------------------------------------------------------------------------------

def decompose(splats: Splats, options: DecomposeOptions = DecomposeOptions(),
              cameras: list[Camera] | None = None) -> DecomposeResult:
    """Estimate per-splat albedo, roughness, metallic and a cubemap light (module docstring).
    ``cameras``: the capture's views (default: :func:`orbit_cameras` from ``options``)."""
    torch.manual_seed(options.seed)
    if cameras is None:
        cameras = orbit_cameras(splats, options.views, options.size, options.fov_y,
                                options.distance)
    views = _prepare_views(splats, cameras)
    n, res = len(splats), options.light_res
    params = {
        "albedo": torch.zeros(n, 3, requires_grad=True),  # sigmoid -> 0.5
        "roughness": torch.zeros(n, requires_grad=True),
        "metallic": torch.full((n,), -3.0, requires_grad=True),
        "light": torch.full((6, res, res, 3), math.log(math.e - 1.0), requires_grad=True),  # 1.0
    }
    opt = torch.optim.Adam(params.values(), lr=options.lr)
    start, losses = 0, []
    ckpt = Path(options.checkpoint) if options.checkpoint else None
    if ckpt is not None and options.resume and ckpt.is_file():
        state = torch.load(ckpt, weights_only=True)
        if state["options"] != asdict(options) | {"iterations": state["options"]["iterations"],
                                                  "resume": state["options"]["resume"],
                                                  "progress": state["options"]["progress"]}:
            raise ValueError(f"{ckpt}: checkpoint was made with other options")
        with torch.no_grad():
            for k, v in state["params"].items():
                params[k].copy_(v)
        opt.load_state_dict(state["optimizer"])
        start, losses = state["iteration"], list(state["losses"])

    def current():
        return (torch.sigmoid(params["albedo"]), torch.sigmoid(params["roughness"]),
                torch.sigmoid(params["metallic"]), torch.nn.functional.softplus(params["light"]))

    bar = tqdm(range(start, options.iterations), disable=not options.progress,
               desc="decompose", initial=start, total=options.iterations)
    for it in bar:
        albedo, rough, metal, light = current()
        l1 = torch.zeros(())
        tv_mat = torch.zeros(())
        for view in views:
            img, maps = render_view(view, albedo, rough, metal, light)
            l1 = l1 + (img - view.target).abs().mean()
            h, w = view.camera.height, view.camera.width
            tv_mat = tv_mat + sum(tv(m.reshape(h, w, -1)) for m in maps.values())
        loss = (l1 + options.lambda_mat * tv_mat) / len(views) + options.lambda_light * tv(light)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()))
        bar.set_postfix(loss=f"{losses[-1]:.4f}")
        done = it + 1
        if ckpt is not None and (done % options.checkpoint_every == 0 or done == options.iterations):
            tmp = ckpt.with_name(ckpt.name + ".tmp")
            torch.save({"params": {k: v.detach() for k, v in params.items()},
                        "optimizer": opt.state_dict(), "iteration": done, "losses": losses,
                        "options": asdict(options)}, tmp)
            tmp.replace(ckpt)
    with torch.no_grad():
        albedo, rough, metal, light = current()
        rendered = torch.cat([render_view(v, albedo, rough, metal, light)[0] for v in views])
        target = torch.cat([v.target for v in views])

    out = dataclasses.replace(splats, albedo=albedo.numpy().astype(np.float32),
                              roughness=rough.numpy().astype(np.float32),
                              metallic=metal.numpy().astype(np.float32), has_materials=True)
    return DecomposeResult(out, light.numpy().astype(np.float32), losses,
                           psnr(rendered.clamp(0, 1), target.clamp(0, 1)), options.iterations)


def relight_error(truth: Splats, estimate: Splats, light: np.ndarray, options: DecomposeOptions
                  = DecomposeOptions()) -> dict:
    """Render ``truth`` and ``estimate`` materials under the same (novel) ``light`` from the
    decomposition views: PSNR (dB) and mean absolute error of the radiance, plus per-splat mean
    absolute errors of albedo, roughness and metallic."""
    cameras = orbit_cameras(truth, options.views, options.size, options.fov_y, options.distance)
    views = _prepare_views(truth, cameras)
    lt = torch.from_numpy(np.asarray(light, np.float32))
    with torch.no_grad():
        a = torch.cat([render_view(v, torch.from_numpy(truth.albedo),
                                   torch.from_numpy(truth.roughness),
                                   torch.from_numpy(truth.metallic), lt)[0] for v in views])
        b = torch.cat([render_view(v, torch.from_numpy(estimate.albedo),
                                   torch.from_numpy(estimate.roughness),
                                   torch.from_numpy(estimate.metallic), lt)[0] for v in views])
    return {"relight_psnr": psnr(a.clamp(0, 1), b.clamp(0, 1)),
            "relight_mae": float((a - b).abs().mean()),
            "albedo_mae": float(np.abs(truth.albedo - estimate.albedo).mean()),
            "roughness_mae": float(np.abs(truth.roughness - estimate.roughness).mean()),
            "metallic_mae": float(np.abs(truth.metallic - estimate.metallic).mean())}


def baked(splats: Splats, light: np.ndarray, degree: int = 2, directions: int = 96) -> Splats:
    """The baked-colour (plain 3DGS) version of a relightable cloud: per splat, SH of ``degree``
    least-squares fitted (3DGS convention, + 0.5 offset) to its shaded radiance under ``light``
    seen from ``directions`` directions over the sphere (view-dependent specular included).
    Materials are reset to the defaults of a plain 3DGS file, normals kept."""
    i = np.arange(directions) + 0.5
    phi = np.arccos(1 - 2 * i / directions)
    theta = np.pi * (1 + 5 ** 0.5) * i
    dirs = np.stack([np.cos(theta) * np.sin(phi), np.cos(phi), np.sin(theta) * np.sin(phi)], -1)
    n = torch.from_numpy(splats.normals).float()[:, None].expand(-1, directions, -1)
    view_to_splat = torch.from_numpy(dirs).float()[None].expand(len(splats), -1, -1)
    # radiance towards the eye: v = -view direction; faces away from the eye use a flipped normal
    v = -view_to_splat
    n = torch.where(((n * v).sum(-1) < 0)[..., None], -n, n)
    with torch.no_grad():
        rad = shade(torch.from_numpy(splats.albedo)[:, None].expand(-1, directions, -1),
                    n, torch.from_numpy(splats.roughness)[:, None].expand(-1, directions),
                    torch.from_numpy(splats.metallic)[:, None].expand(-1, directions),
                    v, torch.from_numpy(light)).numpy()
    k = (degree + 1) ** 2
    basis = sh_basis_3dgs(dirs, k)  # [D, k]
    coef = np.linalg.lstsq(basis, (rad - 0.5).transpose(1, 0, 2).reshape(directions, -1),
                           rcond=None)[0]  # [k, N * 3]
    sh = coef.reshape(k, len(splats), 3).transpose(1, 0, 2).astype(np.float32)
    out = make_splats(splats.means, splats.scales, splats.rotations, splats.opacities, sh=sh,
                      normals=splats.normals)
    return replace(out, source=splats.source)


def synthetic_problem(n: int = 1500, seed: int = 0, light_res: int = 8):
    """(truth relightable splats, true light, baked-colour splats, novel light) for tests and
    ``relight decompose --synthetic``."""
    truth = sphere_splats(n, seed=seed)
    light = sky_cubemap(light_res)
    novel = sky_cubemap(light_res, sun=(-0.6, 0.5, -0.3), sun_power=3.0, tint=(0.8, 0.9, 1.0))
    return truth, light, baked(truth, light), novel


def write_light(path, light: np.ndarray) -> None:
    """The cubemap as a horizontal strip EXR [R, 6R, 3]: faces +X, -X, +Y, -Y, +Z, -Z."""

    strip = np.concatenate(list(np.asarray(light, np.float32)), axis=1)
    write_exr(path, strip, ["R", "G", "B"])


def run(in_path, out_path, options: DecomposeOptions, synthetic: int = 0) -> dict:
    """``relight decompose``: read ``in_path`` (or make a synthetic problem of ``synthetic``
    splats), decompose, write ``out_path`` (relightable PLY) and ``<out>.light.exr``; returns the
    report (re-render PSNR; with a synthetic problem also the relighting error vs the truth)."""


    truth = novel = None
    if synthetic:
        truth, _, splats, novel = synthetic_problem(synthetic, seed=options.seed,
                                                    light_res=options.light_res)
    else:
        splats = read_ply(in_path)
        if len(splats) == 0:
            raise InputError("no splats to decompose", where=in_path)
    result = decompose(splats, options)
    write_ply(out_path, result.splats)
    light_path = Path(out_path).with_suffix(".light.exr")
    write_light(light_path, result.light)
    report = {"splats": len(splats), "views": options.views, "iterations": result.iterations,
              "loss_first": result.losses[0] if result.losses else float("nan"),
              "loss_last": result.losses[-1] if result.losses else float("nan"),
              "rerender_psnr": result.psnr, "out": str(out_path), "light": str(light_path)}
    if truth is not None:
        initial = dataclasses_replace_materials(splats)
        report["relight_initial"] = relight_error(truth, initial, novel, options)
        report["relight"] = relight_error(truth, result.splats, novel, options)
    return report


def dataclasses_replace_materials(splats: Splats) -> Splats:
    """``splats`` with the optimisation's starting materials (albedo 0.5, roughness 0.5,
    metallic sigmoid(-3)): the baseline the relighting error is compared with."""
    n = len(splats)
    return dataclasses.replace(splats, albedo=np.full((n, 3), 0.5, np.float32),
                               roughness=np.full(n, 0.5, np.float32),
                               metallic=np.full(n, 1 / (1 + math.exp(3.0)), np.float32))
