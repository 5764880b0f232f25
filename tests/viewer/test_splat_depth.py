"""``[render] splat_depth``: the expected depth (eq. 6.10) against the median depth on a scene with
known geometry - a splat sphere with semi-transparent floaters in front - and the option's
plumbing (scene validation, renderer)."""
import numpy as np
import pytest

from viewer.scene.camera import Camera
from viewer.splats import concat
from viewer.splats.data import make_splats
from viewer.splats.generate import sphere_splats

RADIUS = 0.8
CAM = Camera(position=(0.0, 0.0, 3.0), target=(0.0, 0.0, 0.0), fov_y=40.0, size=(64, 64),
             near=0.05)


def floaters(n=25, seed=0):
    """Blobs between the camera and the sphere, as training leaves them in front of surfaces."""
    rng = np.random.default_rng(seed)
    means = np.stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n),
                      rng.uniform(1.0, 2.2, n)], -1)
    return make_splats(means, np.exp(rng.uniform(np.log(0.02), np.log(0.06), (n, 3))),
                       rng.normal(size=(n, 4)), rng.uniform(0.2, 0.6, n),
                       albedo=rng.uniform(0, 1, (n, 3)), roughness=np.full(n, 0.5),
                       metallic=np.zeros(n))


def sphere_depth(camera: Camera, radius: float = RADIUS) -> np.ndarray:
    """[H, W] analytic view depth of the sphere surface along each pixel-centre ray (NaN: miss)."""
    w, h = camera.size
    tx, ty = camera.tan_half_fov()
    xs = ((np.arange(w) + 0.5) / w * 2 - 1) * tx
    ys = (1 - (np.arange(h) + 0.5) / h * 2) * ty
    gx, gy = np.meshgrid(xs, ys)
    d = np.stack([gx, gy, -np.ones_like(gx)], -1)  # view space = world space here, z towards eye
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = np.array([0.0, 0.0, 3.0])
    b = d @ o
    disc = b * b - (o @ o - radius ** 2)
    t = -b - np.sqrt(np.where(disc >= 0, disc, np.nan))
    return t * -d[..., 2]  # view depth = distance along the optical axis


def depth_errors(programs, camera=CAM):
    """{mode: (error map, mask of floater pixels, mask of clean pixels)} on the sphere."""
    from learned.parity.checks.splats import render_gl

    sphere, junk = sphere_splats(3000, radius=RADIUS), floaters()
    truth = sphere_depth(camera)
    _, fl = render_gl(programs, junk, camera)
    out = {}
    for mode in ("expected", "median"):
        _, g = render_gl(programs, concat([sphere, junk]), camera, depth=mode)
        inside = np.isfinite(truth) & (g["alpha"][..., 0] > 0.5)
        # inner 90% of the radius: the silhouette's grazing pixels mix sphere and background
        rim = np.isfinite(sphere_depth(camera, 0.9 * RADIUS))
        err = np.abs(g["depth"][..., 0] - truth)
        out[mode] = (err, inside & rim & (fl["alpha"][..., 0] > 0.05),
                     inside & rim & (fl["alpha"][..., 0] == 0))
    return out


def test_median_depth_is_robust_to_floaters(programs):
    res = depth_errors(programs)
    (e_exp, fl, clean), (e_med, _, _) = res["expected"], res["median"]
    assert fl.sum() > 200 and clean.sum() > 200
    mean = {m: (res[m][0][fl].mean(), res[m][0][clean].mean()) for m in res}
    # where floaters cover the sphere, the expected depth is pulled towards them; the median
    # stays on the surface (the floaters cover less than half)
    assert mean["median"][0] < 0.5 * mean["expected"][0], mean
    assert np.percentile(e_med[fl], 90) < np.percentile(e_exp[fl], 90)
    # on clean pixels both are ~2e-2 from the analytic sphere: the median is one splat's centre
    # depth (off by the slope across its footprint), the expected depth averages neighbours
    # (measured 0.023 and 0.018 of a depth of ~2.3)
    assert mean["median"][1] < 0.03 and mean["expected"][1] < 0.03, mean


def test_median_depth_of_two_layers_picks_the_half_coverage_layer(programs):
    """Two flat splats at view depths 1.5 and 2.5: the front one's alpha a1 decides - the median
    is its depth where a1 >= (a1 + (1 - a1) a2) / 2, the back one's otherwise."""
    from learned.parity.checks.splats import render_gl

    def layer(z, opacity):
        return make_splats([[0.0, 0.0, z]], [[0.3, 0.3, 0.01]], [[1.0, 0.0, 0.0, 0.0]], [opacity])

    cam = Camera(position=(0.0, 0.0, 2.0), target=(0.0, 0.0, 0.0), fov_y=40.0, size=(32, 32))
    for front_opacity, expect in ((0.7, 1.5), (0.3, 2.5)):
        _, g = render_gl(programs, concat([layer(-0.5, 0.95), layer(0.5, front_opacity)]), cam,
                         depth="median")
        assert g["depth"][15, 15, 0] == pytest.approx(expect, rel=1e-6)


def test_splat_depth_is_a_validated_render_key(tmp_path):
    from viewer.errors import SceneError
    from viewer.scene.description import scene_from_dict

    s = scene_from_dict({"render": {"splat_depth": "median"}})
    assert s.render.splat_depth == "median" and s.render.flat()["splat_depth"] == "median"
    with pytest.raises(SceneError, match="splat_depth"):
        scene_from_dict({"render": {"splat_depth": "mean"}})


def test_renderer_uses_the_option(ctx, tmp_path):
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict
    from viewer.splats import write_ply

    write_ply(tmp_path / "s.ply", concat([sphere_splats(800, radius=RADIUS), floaters()]))
    base = {"camera": {"position": [0, 0, 3], "fov_y": 40, "size": [32, 32]},
            "environment": {"procedural": "studio"},
            "objects": [{"type": "splats", "path": str(tmp_path / "s.ply")}]}
    r = Renderer(ctx=ctx)
    try:
        depth = {}
        for mode in ("expected", "median"):
            scene = scene_from_dict({**base, "render": {"splat_depth": mode}})
            f = r.render(scene, aovs=("depth", "alpha"))
            assert np.all(np.isfinite(f.radiance))
            depth[mode] = f.aovs["depth"][..., 0]
    finally:
        r.release()
    assert not np.array_equal(depth["expected"], depth["median"])
