"""The environment's shadows ([render] env_shadows; viewer/environment/sampling.py median_cut,
passes/lights.glsl env_shadow) against brute force: a sphere above a Lambertian floor under an
environment with one broad bright panel, the floor's diffuse light with the sphere's occlusion
over the same without (the render with env_shadows over the one without), against the exact
visibility-weighted irradiance ratio integrated over every environment texel (numpy ray-sphere
tests); and what must not change."""
import numpy as np
import pytest
from shadow_scenes import CAMERA, CENTER, HEIGHT, RADIUS, floor_points

from viewer.environment.sampling import median_cut
from viewer.environment.sun import texel_solid_angles
from viewer.imageio import write_exr
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

EH, EW = 64, 128


def panel_environment() -> np.ndarray:
    """A dim uniform sky (0.05) with one bright panel (radiance 4) 40 deg wide in azimuth and
    from 35 to 65 deg up: most of the light, and broad (a studio softbox)."""
    env = np.full((EH, EW, 3), 0.05, np.float32)
    v = (np.arange(EH) + 0.5) / EH
    u = (np.arange(EW) + 0.5) / EW
    elevation = 90.0 - 180.0 * v
    azimuth = 360.0 * (u - 0.5)
    rows = (elevation > 35.0) & (elevation < 65.0)
    cols = np.abs(azimuth - 60.0) < 20.0
    env[np.ix_(rows, cols)] = 4.0
    return env


def env_directions():
    v = (np.arange(EH) + 0.5) / EH
    u = (np.arange(EW) + 0.5) / EW
    phi, theta = 2.0 * np.pi * (u - 0.5), np.pi * v
    st = np.sin(theta)[:, None]
    return np.stack([st * np.sin(phi)[None], np.cos(theta)[:, None] * np.ones(EW)[None],
                     -st * np.cos(phi)[None]], -1)  # lib/equirect.glsl equirect_dir


def truth_ratio(env, x, z):
    """Per floor point (x, 0, z): the irradiance from the unoccluded environment texels over all
    of them (cosine-weighted, upper hemisphere), the sphere tested exactly along each."""
    d = env_directions().reshape(-1, 3)
    power = (env.mean(-1) * texel_solid_angles(EH, EW)[:, None]).reshape(-1) * d[:, 1]
    up = d[:, 1] > 0.0
    d, power = d[up], power[up]
    pts = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], -1)
    out = np.empty(len(pts))
    for i in range(0, len(pts), 256):
        oc = pts[i:i + 256, None, :] - CENTER
        b = (oc * d[None]).sum(-1)
        c = (oc * oc).sum(-1) - RADIUS ** 2
        disc = b * b - c
        blocked = (disc > 0.0) & (-b - np.sqrt(np.maximum(disc, 0.0)) > 0.0)
        out[i:i + 256] = (power[None] * ~blocked).sum(-1) / power.sum()
    return out.reshape(x.shape)


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


@pytest.fixture(scope="module")
def panel(tmp_path_factory):
    path = tmp_path_factory.mktemp("env") / "panel.exr"
    write_exr(path, panel_environment())
    return str(path)


def scene(panel, objects, **render):
    floor = {"type": "plane", "center": [0, 0, 0], "size": [10, 10], "normal": [0, 1, 0],
             "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 1.0, "specular": 0.0}}
    sphere = {"type": "sphere", "center": CENTER.tolist(), "radius": RADIUS,
              "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 1.0, "specular": 0.0}}
    chosen = [floor] + ([sphere] if "sphere" in objects else [])
    return scene_from_dict({"camera": CAMERA, "environment": {"path": panel},
                            "objects": chosen,
                            # no rays: they supersede the environment's shadow maps
                            "render": {"tonemap": "none", "ao": False, "sun": False,
                                       "raytrace": False,
                                       **render}})


def rendered_ratio(renderer, sc, k):
    with_ = renderer.render(sc.with_render(env_shadows=k)).radiance[..., 0]
    without = renderer.render(sc.with_render(env_shadows=0)).radiance[..., 0]
    return with_ / np.maximum(without, 1e-9)


@pytest.mark.parametrize("model", ["ggx_split_sum", "blinn_phong"])
def test_floor_occlusion_matches_brute_force(renderer, panel, model):
    """Eight directions against the exact ratio on the floor (the sphere's own pixels aside).
    Where the sphere hides some of the light (truth below 0.95, down to 0.16), the estimate's
    error is the median cut's (eight lights for a panel and a sky) and PCSS's (a disc's penumbra
    standing for each region's, at most 8.6 deg): measured mean |error| 0.038, mean 0.000,
    95th percentile 0.105; elsewhere mean 0.007 (the discs' penumbrae reach a little past the
    truth's). The bounds are about 1.5x to 2x those: the error is the method's, and moves with
    rounding only in the last digits. Without any occlusion (an estimate of 1) the mean error
    where the sphere hides light would be 0.31."""
    x, z = floor_points()
    truth = truth_ratio(panel_environment(), x, z)
    sc = scene(panel, ("sphere",), model=model)
    ours = rendered_ratio(renderer, sc, 8)
    depth = renderer.render(sc, aovs=("depth",)).aovs["depth"][..., 0]
    m = depth > HEIGHT - 0.01  # the floor (the camera looks straight down from HEIGHT)
    shade = m & (truth < 0.95)  # where the sphere hides some of the light
    err = ours - truth
    assert truth[shade].min() < 0.6 and shade.sum() > 500
    assert np.abs(err[shade]).mean() < 0.06
    assert abs(err[shade].mean()) < 0.03
    assert np.percentile(np.abs(err[shade]), 95) < 0.16
    away = np.abs(err[m & ~shade])
    assert away.mean() < 0.015 and np.percentile(away, 99) < 0.12  # no false shadow elsewhere
    assert np.abs(1.0 - truth[shade]).mean() > 0.1  # an estimate of 1 everywhere fails


def test_nothing_occluding_changes_nothing(renderer, panel):
    """A floor alone: every direction sees it lit (it does not shadow itself), so the render
    with environment shadows is the render without, bit for bit."""
    sc = scene(panel, ())
    a = renderer.render(sc.with_render(env_shadows=8)).radiance
    b = renderer.render(sc.with_render(env_shadows=0)).radiance
    assert np.array_equal(a, b)


def test_shadows_off_draws_no_environment_shadow_pass(renderer, panel):
    sc = scene(panel, ("sphere",), env_shadows=8)
    frame = renderer.draw(sc)
    assert "shadowmapenvdirs" in frame.targets
    frame = renderer.draw(sc.with_render(shadows=False))
    assert "shadowmapenvdirs" not in frame.targets


def test_median_cut_splits_the_power_evenly():
    """Shares sum to 1 and stay near 1 / count (the panel and the sky split by power), the
    directions are unit vectors, and the panel, 60 % of the power, holds most of them."""
    env = panel_environment()
    d, shares, radii = median_cut(env, 8)
    assert d.shape == (8, 3) and np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-5)
    assert shares.sum() == pytest.approx(1.0, abs=1e-5)
    assert shares.min() > 0.5 / 8 and shares.max() < 2.0 / 8
    elevation = np.degrees(np.arcsin(d[:, 1]))
    on_panel = (elevation > 30) & (elevation < 70)
    assert on_panel.sum() >= 4
    assert (radii > 0).all() and (radii < np.pi).all()


def test_median_cut_of_a_black_environment_spreads_over_the_sphere():
    d, shares, _ = median_cut(np.zeros((32, 64, 3), np.float32), 4)
    assert shares.sum() == pytest.approx(1.0, abs=1e-5)
    assert np.abs(d.mean(axis=0)).max() < 0.5


def test_a_model_without_environment_shadows_says_so(renderer, panel):
    """ggx_mc integrates the environment by sampling it: env_shadows is named as unused."""
    import warnings

    from viewer import renderer as renderer_module

    renderer_module._LIGHT_WARNED.discard("env_shadows:ggx_mc")
    sc = scene(panel, ("sphere",), env_shadows=4, model="ggx_mc", samples=1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer.render(sc)
    assert any("env_shadows" in str(w.message) and "ggx_mc" in str(w.message) for w in caught)


def test_rays_supersede_environment_shadows_and_say_so(renderer, panel):
    """Under the ray-traced tier the environment's visibility is traced; the eight maps would
    only darken it twice. They are not drawn, the image is the one without them (bit for bit:
    the rays' sequence does not depend on the setting), and a warning says so, naming the
    setting and how to keep it (raytrace = false)."""
    import warnings

    from viewer import renderer as renderer_module

    renderer_module._LIGHT_WARNED.discard("rays:ggx_split_sum:env_shadows = 8")
    sc = scene(panel, ("sphere",), raytrace=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        frame = renderer.draw(sc.with_render(env_shadows=8))
        a = renderer.render(sc.with_render(env_shadows=8)).radiance
    assert "shadowmapenvdirs" not in frame.targets
    said = [str(w.message) for w in caught if "superseded" in str(w.message)]
    assert len(said) == 1 and "env_shadows = 8 superseded" in said[0] \
        and "raytrace = false" in said[0]
    b = renderer.render(sc.with_render(env_shadows=0)).radiance
    assert np.array_equal(a, b)
    # SSAO and its bounce are the rasteriser's stand-ins for the same light: named too, and off
    renderer_module._LIGHT_WARNED.discard("rays:ggx_split_sum:ssao = true,indirect = true")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        c = renderer.render(sc.with_render(ssao=True, indirect=True)).radiance
    said = [str(w.message) for w in caught if "superseded" in str(w.message)]
    assert len(said) == 1 and said[0].startswith("ssao = true, indirect = true superseded")
    assert np.array_equal(c, b)
