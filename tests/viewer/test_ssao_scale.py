"""SSAO at reduced scale (render.ssao_scale = k): one pixel in k x k marches the rays, a joint
bilateral filter brings O(x) and S(x) to full resolution, the indirect light is gathered at low
resolution and composited at full resolution."""
import numpy as np
import pytest
from ssao_scenes import FLOOR, SSAO, WALL, _read, scene

from viewer.errors import SceneError
from viewer.passes.ssao import low_resolution
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


# ---- reduced scale (render.ssao_scale = k: one pixel in k x k marches, a joint bilateral filter
# fills the rest). What must hold at every k: a flat plane stays exactly unoccluded, a texel's own
# sample pixel keeps its value, occlusion does not bleed across a depth edge, the indirect light
# still brightens creases only, and k = 1 is the full-scale pass. How far k > 1 moves an image is
# measured by `relight bench` (the ssao_scale knob), not asserted. ------------------------------

# a convex sphere hanging in front of the floor/wall crease, far (> ssao_radius) from both: its
# own O(x) is exactly 1, the crease behind its silhouette is dark
HANGING = {"type": "sphere", "center": [0.0, 1.0, 0.6], "radius": 0.35,
           "material": {"albedo": [0.2, 0.4, 0.9], "roughness": 0.8}}


def _low(renderer, sc, t, k):
    tex = t.targets[f"ssao/{k}"].texture
    w, h = tex.size
    return np.frombuffer(tex.read(), np.float32).reshape(h, w, 4)[::-1].copy()


@pytest.mark.parametrize("k", [2, 3, 4])
def test_flat_plane_is_unoccluded_at_every_scale(renderer, k):
    """O(x) = 1 exactly on a plane seen at a grazing angle, with a frame size k does not divide
    (the last texels' sample pixels are clamped): the filter's normalised mean of 1s is 1."""
    sc = scene([FLOOR], position=(0, 0.4, 3.0), ssao=True, ssao_scale=k, **SSAO)
    sc = sc.with_camera(size=(50, 46))  # 3 and 4 divide neither side
    t = renderer.draw(sc)
    ao = _read(t, "ssao")
    covered = t.gbuffer.read(["alpha"])["alpha"][..., 0] > 0
    assert covered.sum() > 500
    np.testing.assert_array_equal(ao[covered], 1.0)
    assert _low(renderer, sc, t, k).shape[:2] == low_resolution((50, 46), k)[::-1]


@pytest.mark.parametrize("k", [2, 4])
def test_sample_pixels_keep_their_texels_values(renderer, k):
    sc = scene([FLOOR, WALL, HANGING], ssao=True, ssao_scale=k, **SSAO)
    t = renderer.draw(sc)
    ao, low = _read(t, "ssao"), _read_low_top_down(renderer, sc, t, k)
    h, w = ao.shape[:2]
    # texel (tx, ty) counted from the bottom marches from pixel (tx k + k // 2, ty k + k // 2)
    ty, tx = np.mgrid[0:low.shape[0], 0:low.shape[1]]
    px, py = np.minimum(tx * k + k // 2, w - 1), np.minimum(ty * k + k // 2, h - 1)
    covered = t.gbuffer.read(["alpha"])["alpha"][::-1][..., 0] > 0  # GL order, as ty/tx
    sel = covered[py, px]
    assert sel.sum() > 50
    gl_ao = ao[::-1]
    np.testing.assert_allclose(gl_ao[py, px][sel], low[sel], rtol=1e-6, atol=0)
    assert (low[sel][..., 0] < 0.9).any()  # the crease: not a test of 1 = 1


@pytest.mark.parametrize("k", [2, 4])
def test_occlusion_does_not_bleed_across_depth_edges(renderer, k):
    """The hanging sphere in front of a dark crease: at reduced scale each sphere pixel's O(x)
    lies within the values of the sphere's own texels among its four taps, never taking the
    crease's (which a plain bilinear upsampling of the same texels does)."""
    sc = scene([FLOOR, WALL, HANGING], ssao=True, ssao_scale=k, **SSAO)
    t = renderer.draw(sc)
    ao = _read(t, "ssao")[::-1][..., 0]  # GL order, as the taps
    low = _read_low_top_down(renderer, sc, t, k)[..., 0]
    sphere = _sphere_mask(t)[::-1]
    h, w = ao.shape
    ys, xs = np.mgrid[0:h, 0:w]
    t0x, t0y = (xs - k // 2) // k, (ys - k // 2) // k  # floor, as the shader's
    fx, fy = (xs - k // 2) / k - t0x, (ys - k // 2) / k - t0y
    vals, own, bil = [], [], []
    for oy in (0, 1):
        for ox in (0, 1):
            tx = np.clip(t0x + ox, 0, low.shape[1] - 1)
            ty = np.clip(t0y + oy, 0, low.shape[0] - 1)
            px, py = np.minimum(tx * k + k // 2, w - 1), np.minimum(ty * k + k // 2, h - 1)
            vals.append(low[ty, tx])
            own.append(sphere[py, px])
            bil.append((fx if ox else 1 - fx) * (fy if oy else 1 - fy))
    vals, own, bil = np.stack(vals), np.stack(own), np.stack(bil)
    sel = sphere & own.any(0)
    lo = np.where(own, vals, np.inf).min(0)
    hi = np.where(own, vals, -np.inf).max(0)
    assert sel.sum() > 100
    assert (ao[sel] >= lo[sel] - 1e-6).all() and (ao[sel] <= hi[sel] + 1e-6).all()
    # the control: the same texels upsampled bilinearly take the crease's values
    plain = (vals * bil).sum(0)
    assert (plain[sel] < lo[sel] - 0.02).any()


def _read_low_top_down(renderer, sc, t, k):
    """The low-resolution target in GL order (row 0 at the bottom)."""
    return _low(renderer, sc, t, k)[::-1]


def _sphere_mask(targets):
    """Pixels of the hanging sphere (its blue albedo; floor and wall are grey and red)."""
    albedo = targets.gbuffer.read(["albedo"])["albedo"]
    return albedo[..., 2] > 0.85


@pytest.mark.parametrize("k", [2, 3])
def test_indirect_at_scale_brightens_creases_only(renderer, k):
    flat = renderer.render(scene([FLOOR], indirect=True, ssao_scale=k, **SSAO)).radiance
    flat_off = renderer.render(scene([FLOOR], **SSAO)).radiance
    np.testing.assert_array_equal(flat, flat_off)  # no hit: E = 0 everywhere
    t = renderer.draw(scene([FLOOR, WALL], ssao=True, indirect=True, ssao_scale=k, **SSAO))
    gain = (_read(t, "radiance") - _read(t, "direct"))[..., :3]
    assert (gain >= 0).all() and np.isfinite(gain).all()
    normal = t.gbuffer.read(["normal"])["normal"]
    floor = normal[..., 1] > 0.9
    first = np.argmax(floor, axis=0)
    rows = np.arange(gain.shape[0])[:, None] - first[None, :]
    near = gain[floor & (rows < 3)].mean()
    far = gain[floor & (rows >= 20)].mean()
    assert near > 2e-3 and far < 1e-4, (near, far)  # full scale: 4.7e-3 and 0
    g = gain[floor & (rows < 3)].mean(0)
    assert g[0] > 1.5 * g[2], g  # the red wall's colour, gathered at low resolution


def test_scale_one_draws_the_full_scale_pass_alone(ctx):
    """k = 1 marches every pixel into the frame's own targets: no low-resolution target, no
    upsampling pass; k = 2 has both (a fresh renderer: targets outlive frames). The bounce's
    blur is off: at k = 1 it gathers into targets of its own (test_ssao_blur.py)."""
    from viewer.gl.timing import PassTimer

    r = Renderer(ctx=ctx)
    r.profiler = timer = PassTimer(ctx)
    try:
        drawn = {}
        for k in (1, 2):
            sc = scene([FLOOR, WALL, HANGING], ssao=True, indirect=True, ssao_scale=k,
                       indirect_blur=False, **SSAO)
            timer.enabled = True
            timer.reset()
            t = r.draw(sc)
            drawn[k] = set(timer.milliseconds())
            timer.enabled = False
            extras = set(t.targets)
            if k == 1:
                assert not any("/" in name for name in extras), extras
        assert "ssao_upsample" not in drawn[1] and "ssao_upsample" in drawn[2], drawn
        assert {"ssao/2", "gathered/2"} <= extras, extras
    finally:
        r.release()


@pytest.mark.parametrize("value", [0, 9, 1.5, "2"])
def test_bad_scale_is_a_scene_error(value):
    with pytest.raises(SceneError, match="ssao_scale"):
        scene_from_dict({"render": {"ssao_scale": value}})


def test_low_resolution_rounds_up():
    assert low_resolution((512, 512), 4) == (128, 128)
    assert low_resolution((50, 47), 3) == (17, 16)
    assert low_resolution((7, 5), 1) == (7, 5)
