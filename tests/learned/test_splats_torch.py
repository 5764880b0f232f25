"""The torch twin rasterizer: parity with the GLSL pass, compositing maths, gradients."""
import numpy as np
import pytest
import torch

from learned.parity.checks.splats import (
    PARITY_ATOL,
    parity_camera,
    parity_check,
    random_scene,
)
from learned.splats.rasterize import rasterize, splat_tensors, weight_matrix
from viewer.scene.camera import Camera
from viewer.splats.data import make_splats


def test_parity_compares_every_channel_of_both_scenes(programs):
    """The splat parity check's two scenes (without and with a mesh) compare every G-buffer
    channel and the median depth, here on 150 splats: the 1500-splat check itself (the same
    function) is `relight parity`'s ``splats``, which tests/shaders/test_library_parity.py runs
    (it was run twice, about 11 s each)."""
    results = parity_check(programs, seeds=(0, 1), n=150)
    # 2 scenes x (19 channels: the glTF dielectric, clearcoat, transmission, sheen, anisotropy,
    # iridescence and dispersion ones too, + the median depth)
    assert len(results) == 38
    for r in results:
        assert r.passed, (r.name, r.max_abs)
        assert r.max_abs < PARITY_ATOL


def test_compositing_matches_a_per_pixel_loop():
    """Brute force: walk each pixel's splats front to back with the scalar formulas."""
    s = random_scene(60, 2, sh_degree=0)
    cam = Camera(position=(0.3, 0.2, 3.0), target=(0, 0, 0), fov_y=50.0, size=(12, 10))
    t = splat_tensors(s)
    with torch.no_grad():
        g = rasterize(t, cam)
    from learned.splats.rasterize import project

    p = project(t, cam)
    order = np.argsort(p["depth"].numpy(), kind="stable")
    for i in range(10):
        for j in range(12):
            x, y = j + 0.5, 10 - i - 0.5
            tr, cov, alb, dep = 1.0, 0.0, np.zeros(3), 0.0
            for k in order:
                if not p["valid"][k]:
                    continue
                dx, dy = x - float(p["centre"][k, 0]), y - float(p["centre"][k, 1])
                a_, b_, c_ = p["conic"][k].tolist()
                d2 = a_ * dx * dx + 2 * b_ * dx * dy + c_ * dy * dy
                if d2 > 8:
                    continue
                al = min(0.99, float(s.opacities[k]) * np.exp(-0.5 * d2))
                if al < 1 / 255:
                    continue
                cov += tr * al
                alb += tr * al * s.albedo[k]
                dep += tr * al * float(p["depth"][k])
                tr *= 1 - al
            assert float(g["alpha"][i, j, 0]) == pytest.approx(cov, abs=1e-5)
            if cov > 0:
                np.testing.assert_allclose(g["albedo"][i, j].numpy(), alb / cov, atol=1e-4)
                assert float(g["depth"][i, j, 0]) == pytest.approx(dep / cov, rel=1e-4)


def test_gradients_reach_materials_opacity_and_geometry():
    s = random_scene(200, 3, sh_degree=1)
    t = splat_tensors(s, requires_grad=True)
    g = rasterize(t, parity_camera((24, 20)))
    loss = sum(g[k].sum() for k in ("color", "albedo", "roughness", "depth"))
    loss.backward()
    for k in ("albedo", "roughness", "opacities", "means", "scales", "sh"):
        grad = t[k].grad
        assert grad is not None and torch.isfinite(grad).all() and grad.abs().sum() > 0, k


def test_weight_matrix_reproduces_the_albedo_map():
    s = random_scene(300, 4, sh_degree=0)
    cam = parity_camera((20, 16))
    t = splat_tensors(s)
    with torch.no_grad():
        g = rasterize(t, cam)
    w = weight_matrix(t, cam)
    acc = torch.sparse.mm(w, t["albedo"])
    cov = g["alpha"].reshape(-1)
    hit = cov > 0
    np.testing.assert_allclose((acc[hit] / cov[hit, None]).numpy(),
                               g["albedo"].reshape(-1, 3)[hit].numpy(), atol=1e-5)


def test_empty_cloud_gives_background():
    s = make_splats(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 4)), np.zeros(0))
    g = rasterize(splat_tensors(s), parity_camera((8, 8)))
    assert float(g["alpha"].abs().sum()) == 0 and torch.isfinite(g["depth"]).all()


def test_median_depth_search_finds_the_half_coverage_splat():
    """The twin's search (3 levels of 16 thresholds, then the nearest splat in the range) against
    the definition, per pixel by brute force: the depth of the first splat, front to back, after
    which the accumulated opacity reaches half the pixel's coverage."""
    from learned.splats.rasterize import alpha_chunks, median_depth

    s = random_scene(80, 4, sh_degree=0)
    cam = Camera(position=(0.3, 0.2, 3.0), target=(0, 0, 0), fov_y=50.0, size=(24, 20))
    t = splat_tensors(s)
    with torch.no_grad():
        parts = list(alpha_chunks(t, cam))
        idx = torch.cat([i for i, _ in parts])
        alpha = torch.cat([a for _, a in parts]).double()  # [N, P] front to back
        from learned.splats.rasterize import project
        depth = project(t, cam)["depth"][idx].double()
        acc = 1.0 - torch.cumprod(1.0 - alpha, 0)
        coverage = acc[-1]
        got = median_depth(t, cam, coverage.float(), torch.zeros_like(coverage).float())
    covered = coverage > 0
    first = ((acc >= 0.5 * coverage[None]) & (alpha > 0)).double().argmax(0)
    want = depth[first]
    agree = (got.double() == want) | ~covered
    assert covered.sum() > 200 and agree.float().mean() > 0.99
