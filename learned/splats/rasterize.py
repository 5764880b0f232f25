"""The torch twin of the GLSL splat pass (``viewer/passes/splats.py``): same projection, same
back-to-front order, same alpha rule, same resolve - differentiable with respect to every splat
attribute (geometry through the conic and centre, materials, SH, opacity).

    tensors = splat_tensors(splats)                    # numpy Splats -> dict of float32 tensors
    gbuffer = rasterize(tensors, camera)               # channel -> [H, W, C], row 0 at the top

Compositing: with splats sorted front to back, T_i = prod_{j<i} (1 - alpha_i) and
``x = sum_i T_i alpha_i x_i`` for the colour (premultiplied) and, divided by the coverage
A = 1 - prod(1 - alpha_i), for albedo, normal (then normalised), roughness, metallic and depth
(thesis eq. 6.10), or, with ``depth="median"``, the median depth of the same weights
(:func:`median_depth`, the search of ``splat_median.frag``). The GLSL pass blends back to front -
the same sums.

Memory: pixels x splats-per-chunk floats per intermediate; every pixel is evaluated against every
splat (no tiling), so this is for tests, parity and small training renders, not for 1M splats.
"""
from __future__ import annotations

from typing import Iterator

import numpy as np
import torch

from learned.twins.splat import (
    MEDIAN_SPLITS,
    splat_alpha,
    splat_conic,
    splat_cov2d,
    splat_cov2d_det,
    splat_depth_refine,
    splat_depth_threshold,
    splat_face_forward,
    splat_mahalanobis2,
    splat_median_target,
    splat_min_axis,
    splat_rotation,
    splat_sh_basis_all,
    splat_view_depth,
)
from viewer.gbuffer import GBufferLayout
from viewer.scene.camera import Camera
from viewer.splats.data import Splats
from viewer.splats.sort import depth_order

FIELDS = ("means", "scales", "rotations", "opacities", "sh", "albedo", "roughness", "metallic",
          "normals")


def splat_tensors(splats: Splats, requires_grad: bool = False) -> dict[str, torch.Tensor]:
    """numpy :class:`Splats` -> dict of float32 tensors with the same names and shapes."""
    return {k: torch.tensor(np.asarray(getattr(splats, k), np.float32),
                            requires_grad=requires_grad) for k in FIELDS}


def project(t: dict[str, torch.Tensor], camera: Camera) -> dict[str, torch.Tensor]:
    """Mirror of ``splat_project.comp``: per-splat centre (GL pixels), conic, colour, normal,
    depth, NDC z and validity (near < depth < far)."""
    view = torch.tensor(camera.view_matrix(), dtype=torch.float32)
    proj = torch.tensor(camera.projection_matrix(), dtype=torch.float32)
    tx, ty = camera.tan_half_fov()
    w, h = camera.width, camera.height
    focal_tan = torch.tensor([w / (2 * tx), h / (2 * ty), tx, ty], dtype=torch.float32)
    means = t["means"]
    t_vs = means @ view[:3, :3].T + view[:3, 3]
    depth = splat_view_depth(view[2], means)  # the cull decision, bit-identical to GLSL's
    valid = (depth > camera.near) & (depth < camera.far)
    r = splat_rotation(t["rotations"])
    m = view[:3, :3] @ r * t["scales"][:, None, :]
    c = m @ m.transpose(1, 2)
    diag = torch.stack([c[:, 0, 0], c[:, 1, 1], c[:, 2, 2]], -1)
    off = torch.stack([c[:, 1, 0], c[:, 2, 0], c[:, 2, 1]], -1)
    safe_t = torch.where(valid[:, None], t_vs, torch.tensor([0.0, 0.0, -1.0]))
    ft = focal_tan.expand(len(means), 4)
    cov2d = splat_cov2d(safe_t, diag, off, ft)
    det = splat_cov2d_det(safe_t, m[:, :, 0], m[:, :, 1], m[:, :, 2], ft)
    conic = splat_conic(cov2d, det)
    clip = torch.cat([safe_t, torch.ones_like(depth)[:, None]], -1) @ proj.T
    ndc = clip[:, :3] / clip[:, 3:]
    centre = (ndc[:, :2] * 0.5 + 0.5) * torch.tensor([float(w), float(h)])
    eye = torch.tensor(camera.position, dtype=torch.float32)
    to_splat = means - eye
    d = to_splat / torch.linalg.vector_norm(to_splat, dim=-1, keepdim=True).clamp_min(1e-30)
    k = t["sh"].shape[1]
    color = (splat_sh_basis_all(d, k)[..., None] * t["sh"]).sum(1) + 0.5
    color = color.clamp_min(0.0)
    n = t["normals"]
    stored = (n * n).sum(-1) > 0
    n = torch.where(stored[:, None], n, splat_min_axis(t["rotations"], t["scales"]))
    n = n / torch.linalg.vector_norm(n, dim=-1, keepdim=True).clamp_min(1e-30)
    n = splat_face_forward(n, -to_splat)
    return {"centre": centre, "conic": conic, "ndc_z": ndc[:, 2], "depth": depth, "valid": valid,
            "color": color, "normal": n}


def _pixel_centres(camera: Camera) -> torch.Tensor:
    """[H * W, 2] GL pixel centres in image row order (row 0 at the top)."""
    w, h = camera.width, camera.height
    ys = h - (torch.arange(h, dtype=torch.float32) + 0.5)
    xs = torch.arange(w, dtype=torch.float32) + 0.5
    gy, gx = torch.meshgrid(ys, xs, indexing="ij")
    return torch.stack([gx, gy], -1).reshape(-1, 2)


def alpha_chunks(t: dict[str, torch.Tensor], camera: Camera, p: dict | None = None,
                 under_depth: torch.Tensor | None = None, order: np.ndarray | None = None,
                 chunk: int = 256) -> Iterator[tuple[torch.Tensor, torch.Tensor]]:
    """Yield ``(index [S], alpha [S, H*W])`` front to back: each splat's alpha at every pixel
    centre (``splat_raster.frag``), 0 where ``under_depth`` [H*W] (view depth of meshes, 0 =
    none) rejects it as the GL depth test does. ``order`` defaults to
    :func:`viewer.splats.sort.depth_order` (reversed)."""
    p = p if p is not None else project(t, camera)
    if order is None:
        order = depth_order(t["means"].detach().numpy(), camera.view_matrix())
    front = torch.from_numpy(np.ascontiguousarray(order[::-1]).astype(np.int64))
    front = front[p["valid"][front]]
    pix = _pixel_centres(camera)
    for s in range(0, len(front), chunk):
        idx = front[s:s + chunk]
        d = pix[None, :, :] - p["centre"][idx][:, None, :]
        d2 = splat_mahalanobis2(d, p["conic"][idx][:, None, :])
        alpha = splat_alpha(t["opacities"][idx][:, None], d2)
        if under_depth is not None:
            blocked = (under_depth[None, :] > 0) & (p["depth"][idx][:, None] >= under_depth[None, :])
            alpha = torch.where(blocked, torch.zeros_like(alpha), alpha)
        yield idx, alpha


def weight_chunks(t: dict[str, torch.Tensor], camera: Camera, p: dict | None = None,
                  under_depth: torch.Tensor | None = None, order: np.ndarray | None = None,
                  chunk: int = 256) -> Iterator[tuple[torch.Tensor, torch.Tensor]]:
    """Yield ``(index [S], weight [S, H*W])`` front to back, weight = T_i alpha_i per pixel
    (arguments as :func:`alpha_chunks`)."""
    transmittance = None
    for idx, alpha in alpha_chunks(t, camera, p, under_depth, order, chunk):
        if transmittance is None:
            transmittance = torch.ones(alpha.shape[1])
        one_minus = 1.0 - alpha
        excl = torch.cumprod(torch.cat([torch.ones_like(one_minus[:1]), one_minus[:-1]], 0), 0)
        tr = transmittance[None, :] * excl
        yield idx, tr * alpha
        transmittance = tr[-1] * one_minus[-1]


MEDIAN_LEVELS = 3  # as viewer.passes.splats.MEDIAN_LEVELS
_FAR = 3.0e38


def median_depth(t: dict[str, torch.Tensor], camera: Camera, coverage: torch.Tensor,
                 under_alpha: torch.Tensor, p: dict | None = None,
                 under_depth: torch.Tensor | None = None, order: np.ndarray | None = None,
                 chunk: int = 256) -> torch.Tensor:
    """Mirror of the median-depth passes (``splat_median.frag``, ``splat_median_update.frag``):
    [H*W] the nearest splat depth in the range the search narrows to (3e38 where no splat
    contributes). ``coverage`` [H*W] the splats' A, ``under_alpha`` [H*W] the alpha under them.
    Not differentiable (a selection). The transmittance at a threshold is read from the running
    front-to-back product (GL multiplies back to front: the same factors, rounded in another
    order). Memory: splats x pixels floats, a few times."""
    p = p if p is not None else project(t, camera)
    n_pix = camera.width * camera.height
    with torch.no_grad():
        parts = list(alpha_chunks(t, camera, p, under_depth, order, chunk))
        if not parts:
            return torch.full((n_pix,), _FAR)
        idx = torch.cat([i for i, _ in parts])
        alpha = torch.cat([a.detach() for _, a in parts])  # [N, P], front to back
        d = p["depth"].detach()[idx]  # [N], non-decreasing (the sort key)
        hit = alpha > 0
        dd = d[:, None].expand_as(alpha)
        lo = torch.where(hit, dd, torch.full_like(dd, _FAR)).amin(0)
        hi = torch.where(hit, dd, torch.zeros_like(dd)).amax(0)
        # transmittance after each splat; at a threshold: after the last splat at or before it
        after = torch.cumprod(1.0 - alpha, 0).T.contiguous()  # [P, N]
        t_target = 1.0 - splat_median_target(coverage, under_alpha)
        rng = torch.stack([lo, hi], -1)
        for _ in range(MEDIAN_LEVELS):
            thr = torch.stack([splat_depth_threshold(rng, k) for k in range(1, MEDIAN_SPLITS + 1)],
                              -1)  # [P, 16]
            j = torch.searchsorted(d.contiguous(), thr.reshape(-1).contiguous(), right=True)
            j = j.reshape(n_pix, MEDIAN_SPLITS) - 1
            trans = torch.where(j >= 0, torch.gather(after, 1, j.clamp_min(0)), 1.0)
            rng = splat_depth_refine(rng, t_target, *trans.split(4, dim=-1))
        pick = hit & (dd >= rng[None, :, 0]) & (dd <= rng[None, :, 1])
        answer = torch.where(pick, dd, torch.full_like(dd, _FAR)).amin(0)
    return answer


def rasterize(t: dict[str, torch.Tensor], camera: Camera,
              under: dict[str, torch.Tensor] | None = None, order: np.ndarray | None = None,
              chunk: int = 256, depth: str = "expected") -> dict[str, torch.Tensor]:
    """The splat G-buffer: channel -> [H, W, C] float32 (row 0 at the top), every channel of
    ``GBufferLayout(with_color=True)``. ``under``: the G-buffer already drawn (meshes; channel ->
    [H, W, C]); splats behind its depth are rejected and the result is composited over it as in
    ``splat_resolve.frag``. Without ``under``, uncovered pixels hold background values.
    ``depth``: "expected" (eq. 6.10) or "median" (:func:`median_depth`), as ``[render]
    splat_depth``."""
    h, w = camera.height, camera.width
    p = project(t, camera)
    attrs = torch.cat([p["color"], t["albedo"], p["normal"], t["roughness"][:, None],
                       t["metallic"][:, None], p["depth"][:, None]], -1)  # [N, 12]
    acc = torch.zeros(h * w, 12)
    coverage = torch.zeros(h * w)
    under_depth = None
    if under is not None:
        ua = under["alpha"].reshape(-1)
        under_depth = torch.where(ua > 0, under["depth"].reshape(-1), torch.zeros_like(ua))
    for idx, wgt in weight_chunks(t, camera, p, under_depth, order, chunk):
        acc = acc + wgt.T @ attrs[idx]
        coverage = coverage + wgt.sum(0)
    # coverage as GL accumulates it: 1 - prod(1 - alpha) equals sum T_i alpha_i
    median = None
    if depth == "median":
        ua = torch.zeros(h * w) if under is None else under["alpha"].reshape(-1)
        median = median_depth(t, camera, coverage.detach(), ua, p, under_depth, order)
    elif depth != "expected":
        raise ValueError(f"depth must be 'expected' or 'median', not {depth!r}")
    return resolve(acc, coverage, (h, w), under, median)


def resolve(acc: torch.Tensor, coverage: torch.Tensor, size_hw: tuple[int, int],
            under: dict[str, torch.Tensor] | None = None,
            median: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
    """Mirror of ``splat_resolve.frag``. acc [P, 12] = sums of T a (colour, albedo, normal,
    roughness, metallic, depth); coverage [P]; ``median`` [P] (:func:`median_depth`) replaces the
    expected depth as with ``SPLAT_DEPTH_MEDIAN``."""
    h, w = size_hw
    layout = GBufferLayout(with_color=True, with_emission=True, with_dielectric=True,
                           with_clearcoat=True, with_transmission=True,
                           with_sheen=True, with_anisotropy=True, with_iridescence=True,
                           with_dispersion=True)  # every channel GL reads back
    bg = {k: torch.from_numpy(v.reshape(h * w, -1)) for k, v in layout.background(h, w).items()}
    base = bg if under is None else {k: under[k].reshape(h * w, -1) if k in under else bg[k]
                                     for k in bg}
    w_under = (1.0 - coverage) * base["alpha"][:, 0]
    total = coverage + w_under
    hit = total > 0
    safe = torch.where(hit, total, torch.ones_like(total))[:, None]
    wu = w_under[:, None]
    n = acc[:, 6:9] + wu * base["normal"]
    nn = torch.linalg.vector_norm(n, dim=-1, keepdim=True)
    out = {
        "alpha": total[:, None],
        "albedo": (acc[:, 3:6] + wu * base["albedo"]) / safe,
        "normal": torch.where(nn > 0, n / nn.clamp_min(1e-30), torch.zeros_like(n)),
        "roughness": (acc[:, 9:10] + wu * base["roughness"]) / safe,
        "metallic": (acc[:, 10:11] + wu * base["metallic"]) / safe,
        "specular": (coverage[:, None] * 0.5 + wu * base["specular"]) / safe,
        "ao": (coverage[:, None] + wu * base["ao"]) / safe,
        "depth": (acc[:, 11:12] + wu * base["depth"]) / safe,
        "color": acc[:, 0:3] + wu * base["albedo"],
        "emission": wu * base["emission"] / safe,  # splats emit nothing; they hide what does
        # the glTF lobe underneath (a >= 0) blends with the splats' (0.04, 0.04, 0.04, 1)
        "dielectric": torch.where(
            base["dielectric"][:, 3:] >= 0.0,
            (coverage[:, None] * torch.tensor([0.04, 0.04, 0.04, 1.0]) + wu * base["dielectric"])
            / safe, base["dielectric"]),
        # splats have no coat: its factor blends to 0 over them (roughness, normal: underneath)
        "clearcoat": torch.cat([wu * base["clearcoat"][:, :1] / safe, base["clearcoat"][:, 1:]],
                               -1),
        # splats are opaque: the transmission factor blends to 0 (the IOR: underneath)
        "transmission": wu * base["transmission"] / safe,
        "transmission_ior": base["transmission_ior"],
        "dispersion": base["dispersion"],  # (KHR_materials_dispersion: underneath, as the IOR)
        # nor a sheen: its colour blends to 0 over them (its roughness: underneath)
        "sheen": torch.cat([wu * base["sheen"][:, :3] / safe, base["sheen"][:, 3:]], -1),
        # nor an anisotropic lobe: its strength x direction blends to 0 over them
        "anisotropy": wu * base["anisotropy"] / safe,
        # nor a thin film: its factor blends to 0 (its thickness and IOR: underneath)
        "iridescence": torch.cat([wu * base["iridescence"][:, :1] / safe,
                                  base["iridescence"][:, 1:]], -1),
    }
    if median is not None:
        on_splat = (coverage >= splat_median_target(coverage, base["alpha"][:, 0])) & (median < 1e30)
        out["depth"] = torch.where(on_splat, median, base["depth"][:, 0])[:, None]
    return {k: torch.where(hit[:, None], v, base[k]).reshape(h, w, -1) for k, v in out.items()}


def weight_matrix(t: dict[str, torch.Tensor], camera: Camera, chunk: int = 256
                  ) -> torch.Tensor:
    """Sparse [H*W, N] matrix of T_i alpha_i (no gradient: fixed geometry), for training renders
    that only change per-splat attributes: ``maps = W @ attributes``."""
    rows, cols, vals = [], [], []
    with torch.no_grad():
        for idx, wgt in weight_chunks(t, camera, chunk=chunk):
            s, pix = torch.nonzero(wgt, as_tuple=True)
            rows.append(pix)
            cols.append(idx[s])
            vals.append(wgt[s, pix])
    n = t["means"].shape[0]
    p = camera.width * camera.height
    if not rows:
        return torch.sparse_coo_tensor(torch.zeros(2, 0, dtype=torch.int64), torch.zeros(0), (p, n),
                                       check_invariants=False)
    return torch.sparse_coo_tensor(torch.stack([torch.cat(rows), torch.cat(cols)]),
                                   torch.cat(vals), (p, n), check_invariants=False).coalesce()


# ---- parity: GLSL splat pass vs this twin ------------------------------------------------------
