"""Shadow maps as views: ``relight render --aov shadow<i>`` / ``shadowsun`` reads a frame's map
(a point light's cube atlas, 3 x 2 faces), and the viewer's debug view pass shows it."""
import numpy as np
import pytest

from viewer.errors import SceneError
from viewer.frame import check_aovs
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def scene():
    return scene_from_dict({
        "camera": {"position": [0, 5, 0.01], "target": [0, 0, 0], "fov_y": 60, "size": [32, 32]},
        "environment": {"procedural": "white", "width": 32, "intensity": 0.0},
        "lights": [{"type": "directional", "direction": [0.3, 1, 0.2]},
                   {"type": "point", "position": [0.5, 3, 0.0]}],
        "objects": [{"type": "plane", "center": [0, 0, 0], "size": [10, 10], "normal": [0, 1, 0]},
                    {"type": "sphere", "center": [0, 1, 0], "radius": 0.5}],
        # every map at its set size (the shadow budget would share one map's texels between the
        # two lights: tests/viewer/test_shadow_budget.py)
        "render": {"shadow_size": 256, "shadow_cube_size": 64, "shadow_budget": 0}})


def test_shadow_maps_as_aovs(renderer):
    frame = renderer.render(scene(), aovs=("shadow0", "shadow1", "depth"))
    flat, cube = frame.aovs["shadow0"], frame.aovs["shadow1"]
    assert flat.shape == (256, 256, 1) and cube.shape == (128, 192, 1)
    for m in (flat, cube):
        assert 0.0 <= m.min() and m.max() <= 1.0
        assert m.min() < 0.9  # geometry in it
    # the point light above the scene: its -Y face (atlas tile (0, 1): top-left in image rows)
    # sees the sphere under it (the floor, lit from above, hides nothing: it is left out), its
    # +Y face (tile (2, 0)) nothing
    down = cube[:64, :64, 0]
    up = cube[64:, 128:, 0]
    assert down.min() < 1.0 and (up == 1.0).all()
    with pytest.raises(SceneError, match="no shadow map 'shadow5'.*shadow0, shadow1"):
        renderer.render(scene(), aovs=("shadow5",))
    check_aovs(["shadowsun", "shadow12", "albedo"])
    with pytest.raises(SceneError, match="unknown AOV 'shadows'"):
        check_aovs(["shadows"])


def test_the_debug_view_shows_a_shadow_map(renderer):
    from viewer.frame import read_texture
    from viewer.passes.debug_view import DebugViewPass, shadow_views

    ctx = renderer.ctx
    targets = renderer.draw(scene())
    assert shadow_views(targets) == ("shadow0", "shadow1")
    want = read_texture(targets.targets["shadowmap0"].texture, "f4")[..., 0]
    view = DebugViewPass(renderer.programs)
    tex = ctx.texture((256, 256), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[tex])
    try:
        fbo.use()
        ctx.viewport = (0, 0, 256, 256)
        view.run(targets, "shadow0")
        got = read_texture(tex, "f4")[..., 0]
        np.testing.assert_allclose(got, want, atol=1e-6)
        with pytest.raises(SceneError, match="no shadow map 'shadowsun'"):
            view.run(targets, "shadowsun")
    finally:
        fbo.release()
        tex.release()
        view.release()
