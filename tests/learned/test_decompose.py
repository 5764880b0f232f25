"""Decomposition of baked-colour splats into materials + cubemap light on a known synthetic scene."""
import json
import math

import numpy as np
import pytest
import torch

from learned.splats.decompose import (DecomposeOptions, dataclasses_replace_materials, decompose,
                                      relight_error, shade, synthetic_problem)


def test_shade_white_furnace_lambert():
    """A white Lambertian surface under a constant unit cubemap reflects exactly 1 (diffuse)."""
    from viewer.splats.generate import cube_solid_angles

    assert cube_solid_angles(16).sum() == pytest.approx(4 * math.pi, rel=1e-3)
    n = torch.tensor([[0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    out = shade(torch.ones(2, 3), n, torch.ones(2), torch.zeros(2), n, torch.ones(6, 16, 16, 3))
    diffuse = out - shade(torch.zeros(2, 3), n, torch.ones(2), torch.zeros(2), n,
                          torch.ones(6, 16, 16, 3))
    # texel quadrature of the clamped cosine at 16^2 per face: measured 2.1e-3 high
    np.testing.assert_allclose(diffuse.numpy(), 1.0, rtol=5e-3)


@pytest.mark.slow
def test_decomposition_reduces_loss_and_error_vs_truth(tmp_path):
    truth, light, baked, novel = synthetic_problem(300)
    opts = DecomposeOptions(views=4, size=24, iterations=40, lr=0.08, progress=False,
                            checkpoint=str(tmp_path / "ck.pt"), checkpoint_every=20)
    r = decompose(baked, opts)
    assert r.losses[-1] < 0.3 * r.losses[0]
    assert r.psnr > 25.0
    before = relight_error(truth, dataclasses_replace_materials(baked), novel, opts)
    after = relight_error(truth, r.splats, novel, opts)
    assert after["relight_mae"] < 0.85 * before["relight_mae"]
    assert after["albedo_mae"] < before["albedo_mae"]
    assert (tmp_path / "ck.pt").is_file()
    # resume: a longer run continues from iteration 40 with the same history
    more = decompose(baked, DecomposeOptions(**{**opts.__dict__, "iterations": 45}))
    assert len(more.losses) == 45 and more.losses[:40] == r.losses


def test_cli_decompose_synthetic_and_bad_input(tmp_path, capsys):
    from relight.cli import main
    from viewer.splats import read_ply

    out = tmp_path / "out.ply"
    assert main(["decompose", "--synthetic", "120", "--out", str(out), "--views", "2",
                 "--size", "16", "--iterations", "3", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["splats"] == 120 and "relight" in report and math.isfinite(report["rerender_psnr"])
    s = read_ply(out)
    assert s.has_materials and len(s) == 120
    assert (tmp_path / "out.light.exr").is_file()
    bad = tmp_path / "bad.ply"
    bad.write_text("not a ply")
    assert main(["decompose", str(bad), "--out", str(tmp_path / "x.ply")]) == 2
    assert "bad.ply" in capsys.readouterr().err
    assert not (tmp_path / "x.ply").exists()
