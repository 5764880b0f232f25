"""The bilateral blur of SSAO's occlusion (render.ssao_blur, passes/ssao_blur.frag): it removes the
rays' per-pixel noise on a surface and does not carry occlusion across a depth edge.

Measured on llvmpipe (the floor of the floor/wall crease, within 12 rows of it, 48x48): the
variance of the difference between horizontally neighbouring pixels' O(x) drops 51x with 4 rays,
59x with 8 and 50x with 16 at ssao_scale 1 (6-8x at ssao_scale 2, whose upsampling already
smooths); the region's mean moves by +0.003 (the crease's gradient is smoothed)."""
import numpy as np
import pytest

from ssao_scenes import FLOOR, SSAO, WALL, _read, scene
from viewer.renderer import Renderer

# a convex sphere hanging in front of the crease, far (> ssao_radius) from both
HANGING = {"type": "sphere", "center": [0.0, 1.0, 0.6], "radius": 0.35,
           "material": {"albedo": [0.2, 0.4, 0.9], "roughness": 0.8}}


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _raw(targets):
    tex = targets.targets["ssao/raw"].texture
    w, h = tex.size
    return np.frombuffer(tex.read(), np.float32).reshape(h, w, 4)[::-1].copy()


@pytest.mark.parametrize("k, drop", [(1, 20.0), (2, 4.0)])
def test_blur_removes_the_per_pixel_noise(renderer, k, drop):
    t = renderer.draw(scene([FLOOR, WALL], ssao=True, ssao_blur=True, ssao_scale=k,
                            **{**SSAO, "ssao_rays": 4}))
    ao, raw = _read(t, "ssao")[..., 0], _raw(t)[..., 0]
    floor = t.gbuffer.read(["normal"])["normal"][..., 1] > 0.9
    rows = np.arange(floor.shape[0])[:, None] - np.argmax(floor, axis=0)[None, :]
    region = floor & (rows < 12)  # the occluded band of the floor beside the crease
    pair = region[:, 1:] & region[:, :-1]
    noise_raw = (raw[:, 1:] - raw[:, :-1])[pair].var()
    noise = (ao[:, 1:] - ao[:, :-1])[pair].var()
    print(f"scale {k}: neighbour-difference variance {noise_raw:.2e} -> {noise:.2e} "
          f"({noise_raw / noise:.0f}x less); mean {raw[region].mean():.4f} -> "
          f"{ao[region].mean():.4f}")
    assert pair.sum() > 300 and raw[region].mean() < 0.97  # an occluded, noisy region
    assert noise <= noise_raw / drop
    assert abs(ao[region].mean() - raw[region].mean()) < 0.01  # smoothed, not brightened
    # an unoccluded plane stays exactly 1 (a weighted mean of ones)
    t = renderer.draw(scene([FLOOR], ssao=True, ssao_blur=True, ssao_scale=k, **SSAO))
    covered = t.gbuffer.read(["alpha"])["alpha"][..., 0] > 0
    np.testing.assert_array_equal(_read(t, "ssao")[..., 0][covered], 1.0)


def test_blur_does_not_bleed_across_a_depth_edge(renderer, ctx):
    """The sphere in front of the dark crease: blurring an occlusion image in which either side
    is replaced (by 0 or by 1) leaves every pixel of the other side bit for bit unchanged."""
    sc = scene([FLOOR, WALL, HANGING], ssao=True, ssao_blur=True, **SSAO)
    t = renderer.draw(sc)
    sphere = t.gbuffer.read(["albedo"])["albedo"][..., 2] > 0.85  # its blue albedo
    covered = t.gbuffer.read(["alpha"])["alpha"][..., 0] > 0
    behind = covered & ~sphere
    raw = _raw(t)
    assert sphere.sum() > 100 and raw[..., 0][behind].min() < 0.7  # a dark crease behind it
    sspass = renderer.resources.layout_pass("ssao", renderer.specialization(sc).layout)
    h, w = raw.shape[:2]
    src = ctx.texture((w, h), 4, dtype="f4")
    dst = ctx.texture((w, h), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[dst])
    try:
        def blurred(image):
            src.write(np.ascontiguousarray(image[::-1], np.float32).tobytes())
            sspass.blur(t.gbuffer.textures, src, fbo, t.camera, env_vis=False)
            return np.frombuffer(dst.read(), np.float32).reshape(h, w, 4)[::-1][..., 0]

        base = blurred(raw)
        for side, other in ((sphere, behind), (behind, sphere)):
            for value in (0.0, 1.0):
                changed = raw.copy()
                changed[side] = value
                np.testing.assert_array_equal(blurred(changed)[other], base[other])
    finally:
        fbo.release()
        src.release()
        dst.release()


def test_ssao_blur_is_a_render_setting(renderer):
    from viewer.errors import SceneError

    with pytest.raises(SceneError, match="render.ssao_blur must be true or false"):
        scene([FLOOR], ssao=True, ssao_blur="yes")
    graph = renderer.graph(scene([FLOOR], ssao=True, ssao_blur=False))
    assert "ssao_blur" not in [p.name for p in graph.passes]


def test_the_denoised_indirect_light_keeps_its_energy_and_loses_its_speckle(renderer):
    """``indirect_blur``: the one-bounce light gathered at full resolution goes through
    the same bilateral blur before it is added (passes: indirect_gather, indirect_blur,
    indirect). On the floor beside the red wall (the band the wall's bounce lights) the
    pixel-to-pixel noise of the indirect light falls (measured 8 rays: 62x less
    neighbour-difference variance), and the bounce's total over the surfaces stays (measured
    -0.8 %: the 5 x 5 filter spreads the crease's bright rows over the next two, it does not add
    light); off, the frame is the one-pass indirect light bit for bit. The GL passes against
    their twins: ``learned/parity/checks/ssao.py`` (ssao:denoise)."""
    common = dict(ssao=True, indirect=True, ssao_blur=True, **{**SSAO, "ssao_rays": 8})
    plain = renderer.draw(scene([FLOOR, WALL], **common, indirect_blur=False))
    direct = _read(plain, "direct")[..., :3]  # read now: the next draw reuses the targets
    noisy, before = _read(plain, "radiance")[..., :3] - direct, _read(plain, "radiance")
    covered = plain.gbuffer.read(["alpha"])["alpha"][..., 0] > 0
    floor = plain.gbuffer.read(["normal"])["normal"][..., 1] > 0.9
    assert "gathered/blur" not in plain.targets
    den = renderer.draw(scene([FLOOR, WALL], **common, indirect_blur=True))
    assert "gathered/blur" in den.targets
    np.testing.assert_array_equal(_read(den, "direct")[..., :3], direct)
    smooth = _read(den, "radiance")[..., :3] - direct
    rows = np.arange(floor.shape[0])[:, None] - np.argmax(floor, axis=0)[None, :]
    region = floor & (rows < 12)  # the band the wall's bounce lights
    pair = region[:, 1:] & region[:, :-1]
    lum = lambda x: x.sum(-1)
    var = lambda x: (lum(x)[:, 1:] - lum(x)[:, :-1])[pair].var()
    total = lum(noisy)[covered].sum()
    print(f"indirect beside the crease: variance {var(noisy):.2e} -> {var(smooth):.2e}; total "
          f"{total:.3f} -> {lum(smooth)[covered].sum():.3f}")
    assert pair.sum() > 300 and total > 10.0  # a lit, noisy band
    assert var(smooth) <= var(noisy) / 5
    assert abs(lum(smooth)[covered].sum() / total - 1) < 0.02
    again = renderer.draw(scene([FLOOR, WALL], **common, indirect_blur=False))
    np.testing.assert_array_equal(_read(again, "radiance"), before)
