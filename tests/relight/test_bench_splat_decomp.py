"""relight.bench.splat_decomp: the decomposition-vs-relit-truth pipeline end to end on a tiny case
(torch-shaded bake and truth instead of the path tracer, one relighting environment), its
ordering where it must hold, and broken decompositions scoring below the real one."""
import numpy as np
import pytest

pytest.importorskip("torch")

from relight.bench.splat_decomp import SplatDecompConfig, invert, scene_rows, scramble  # noqa: E402
from relight.bench.splat_relight import environment_cubemap, shaded_truth  # noqa: E402
from relight.bench.splat_scenes import decomp_scenes, surface_splats  # noqa: E402
from viewer.environment.maps import EnvironmentSpec  # noqa: E402
from viewer.splats.generate import cube_solid_angles  # noqa: E402

# ~200 splats, 4 capture views of 24^2, 40 steps; relit under the procedural studio, whose
# lights the renderer does not shadow-map, so truth (no visibility) and ceiling differ by the
# shading approximations alone. decompose's own lambda_M: at 24^2 the suite's stronger material
# TV flattens the maps towards one material, and inverting that changes little
TINY = SplatDecompConfig(size=32, spacing=0.2, bake="shaded", views=4, view_size=24,
                         iterations=40, light_res=4, lambda_mat=0.02, scenes=("three_spheres",),
                         progress=False, relight=("studio",))


@pytest.fixture(scope="module")
def row(ctx, tmp_path_factory):
    from viewer.renderer import Renderer

    scene = decomp_scenes(TINY.size)["three_spheres"]
    truth = surface_splats(scene, TINY.spacing)
    r = Renderer(ctx=ctx)
    try:
        (out,) = scene_rows(r, "three_spheres", scene, TINY, tmp_path_factory.mktemp("sd"),
                            extra={"scrambled": scramble, "inverted": invert},
                            truth_fn=lambda s, env, name: shaded_truth(s, truth, env))
    finally:
        r.release()
    return out


def test_environment_cubemap_keeps_the_energy():
    """The cubemap bins the equirect map's energy: its integral over the sphere equals the
    map's (to float32 rounding)."""
    from viewer.environment.maps import load_environment
    from viewer.environment.sun import texel_solid_angles

    spec = EnvironmentSpec(procedural="sky")
    env = load_environment(spec).astype(np.float64)
    h, w = env.shape[:2]
    total = (env * np.repeat(texel_solid_angles(h, w), w).reshape(h, w, 1)).sum((0, 1))
    cube = environment_cubemap(spec, 8).astype(np.float64)
    got = (cube * cube_solid_angles(8)[..., None]).sum((0, 1, 2))
    np.testing.assert_allclose(got, total, rtol=1e-5)


def test_pipeline_runs_and_orders(row):
    """Every method is scored on the same pixels; the ceiling (true materials) beats the
    decomposition by a margin and the decomposition beats the floor (the capture's colours,
    lit by another environment) on this case, whose truth is the decomposition's own model."""
    assert row["relit"] == "studio" and row["pixels"] > 200
    assert row["psnr_ceiling"] > row["psnr_decomposition"] + 3.0
    assert row["psnr_decomposition"] > row["psnr_floor"]
    assert row["psnr_aligned"] > row["psnr_floor"]


def test_broken_decompositions_score_below(row):
    """Inverted materials (1 - x) lose at least 6 dB against the decomposition; permuted ones
    score no better than it."""
    assert row["psnr_inverted"] < row["psnr_decomposition"] - 6.0
    assert row["psnr_scrambled"] < row["psnr_decomposition"]
