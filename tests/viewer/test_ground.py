"""The shadow-catcher ground (``--floor``, viewer.passes.ground, issue 37): a box on the catcher
under the procedural sky, seen from 45 degrees up and twice as far as the framing puts it, so
the catcher's edge is in the frame. Every pixel is compared with the same view of the box alone
(the environment behind it): away from the shadow the catcher is that environment (its edge does
not show), the sun's shadow darkens it by a stated ratio (shadow maps; the ray-traced tier too),
and ``--floor slab`` is the grey plane it was."""
import warnings

import numpy as np
import pytest
from asset_files import box_gltf

from viewer.renderer import Renderer
from viewer.scene.assets import open_assets
from viewer.scene.bounds import Bounds
from viewer.scene.framing import frame_camera, view_direction

SIZE = (96, 72)
LO, HI = np.array([-0.3, 0.0, -0.3]), np.array([0.3, 0.8, 0.3])
LUMA = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    return box_gltf(tmp_path_factory.mktemp("ground") / "box.glb", lo=LO, hi=HI)


def _render(renderer, box, floor, size=SIZE, **render):
    """``(linear radiance [H, W, 4], albedo [H, W, 3])`` of the box (and its floor)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        opened = open_assets([box], env="sky", floor=floor, size=size)
        for obj, content in opened.contents:
            renderer.add_geometry(obj, content)
        scene = opened.scene
        cam = frame_camera(Bounds(tuple(LO), tuple(HI)), scene.camera.fov_y, size,
                           direction=view_direction(45.0, 30.0))
        target = np.asarray(cam.target)
        position = target + 2.0 * (np.asarray(cam.position) - target)
        scene = scene.with_camera(position=tuple(position.tolist()), target=cam.target,
                                  near=0.05, far=100.0)
        frame = renderer.render(scene.with_render(tonemap="none", **render), aovs=("albedo",))
    return frame.radiance, frame.aovs["albedo"]


@pytest.fixture(scope="module")
def bare(renderer, box):
    return _render(renderer, box, None)[0]  # the box alone: the environment everywhere else


def _ratio(rad, bare):
    """``[H, W]`` luminance of ``rad`` over the bare environment's."""
    return (rad[..., :3] @ LUMA) / np.maximum(bare[..., :3] @ LUMA, 1e-6)


def _beside(mask):
    """Pixels with a 4-neighbour in ``mask``."""
    m = np.pad(mask, 1)
    return m[:-2, 1:-1] | m[2:, 1:-1] | m[1:-1, :-2] | m[1:-1, 2:]


def test_the_catcher_fades_into_the_environment_and_catches_the_shadow(renderer, box, bare):
    # shadow maps (the rays' ratio is below 1 wherever the box hides a little sky, which is
    # everywhere on the plane: the next test)
    rad, _ = _render(renderer, box, "catcher", raytrace=False)
    around = bare[..., 3] < 0.5  # not the box
    plane = (rad[..., 3] > 0.5) & around
    ratio = _ratio(rad, bare)
    edge = plane & _beside(around & ~plane)  # the plane's pixels beside the bare environment
    assert edge.sum() > 20 and (around & ~plane).sum() > 100  # its edge is in the frame
    # no plane shows: never brighter than the environment behind it, and at its edge (and
    # everywhere off the shadow) that environment itself (background x 1: exact)
    assert ratio[around].max() <= 1.0 + 1e-4
    np.testing.assert_allclose(ratio[edge], 1.0, atol=1e-4)
    assert (np.abs(ratio[plane] - 1.0) < 1e-4).mean() > 0.8
    # the sun's shadow beside the box: at most half the light of the ground around it
    # (measured: 0.34 at its darkest, 8 % of the plane's pixels under 0.53, 533 under 0.8)
    assert ratio[plane].min() < 0.5 and (ratio[plane] < 0.8).sum() >= 20


def test_the_raytraced_tier_darkens_the_catcher(renderer, box, bare):
    """The default render's rays (``[render] raytrace``): the traced visibility darkens the
    catcher as the maps do (measured: 0.22 at its darkest, 13 % of the plane under 0.8); the
    environment behind is the same, and the catcher's edge is that environment."""
    rad, _ = _render(renderer, box, "catcher")
    around = bare[..., 3] < 0.5
    plane = (rad[..., 3] > 0.5) & around
    edge = plane & _beside(around & ~plane)
    assert edge.sum() > 20
    np.testing.assert_allclose(_ratio(rad, bare)[edge], 1.0, atol=1e-4)
    ratio = _ratio(rad, bare)[plane]
    assert ratio.max() <= 1.0 + 1e-4 and ratio.min() < 0.5 and (ratio < 0.8).sum() >= 20


@pytest.mark.parametrize("scale", [1, 2])
def test_the_screen_space_bounce_skips_the_catcher(renderer, box, bare, scale):
    """``[render] indirect`` (and the neural students, which turn it on) add their bounce after
    the lighting pass: not on the catcher, which would show (measured without the guard: up to
    14 x the environment beside the box at scale 1, 8.6 x at scale 2)."""
    rad, _ = _render(renderer, box, "catcher", indirect=True, ssao_scale=scale, raytrace=False)
    plane = (rad[..., 3] > 0.5) & (bare[..., 3] < 0.5)
    ratio = _ratio(rad, bare)[plane]
    assert ratio.max() <= 1.0 + 1e-4 and ratio.min() < 0.5


def test_the_slab_is_still_a_grey_plane_with_the_shadow(renderer, box, bare):
    rad, albedo = _render(renderer, box, "slab")
    slab = (np.abs(albedo - 0.5) < 0.01).all(axis=-1) & (bare[..., 3] < 0.5)
    assert slab.sum() > 500
    lum = rad[..., :3] @ LUMA
    assert np.percentile(lum[slab], 95) > 2.0 * np.percentile(lum[slab], 5)  # the sun's shadow
    assert np.median(np.abs(_ratio(rad, bare)[slab] - 1.0)) > 0.1  # a plane, not the environment


def test_floor_kinds_in_the_scene(tmp_path, box):
    from viewer.errors import SceneError
    from viewer.scene.description import load_scene
    from viewer.scene.files import save_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        catcher = open_assets([box], floor=True).scene
        slab = open_assets([box], floor="slab").scene
    assert catcher.objects[1].catcher and not slab.objects[1].catcher
    assert catcher.objects[1].size[0] > slab.objects[1].size[0]  # its fade ends inside it
    path = save_scene(catcher, tmp_path / "s.toml")
    assert "catcher = true" in path.read_text()
    assert load_scene(path).objects[1] == catcher.objects[1]
    with pytest.raises(SceneError, match="floor must be one of catcher, slab"):
        open_assets([box], floor="wood")
    (tmp_path / "bad.toml").write_text("[[objects]]\ntype = 'plane'\ncatcher = 1\n")
    with pytest.raises(SceneError, match="catcher must be true or false"):
        load_scene(tmp_path / "bad.toml")
