"""Image-space G-buffer stacks: the 12-channel EXR round trip and FFHQ256-PBR sample folders."""
import json
from pathlib import Path

import numpy as np

from viewer.gbuffer import CHANNELS

CHANNEL_BACKGROUND = {c.name: c.background[0] for c in CHANNELS}
import pytest

from viewer.errors import InputError
from viewer.geometry.imagespace import (
    ImageGBuffer,
    load_ffhq_pbr,
    load_stack_exr,
    save_stack_exr,
    view_dirs_cs,
)
from viewer.imageio import read_image, write_exr, write_png
from viewer.scene.camera import Camera

H, W = 12, 16


def _stack(seed=0) -> ImageGBuffer:
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(H, W, 3)) + [0, 0, 2]
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    alpha = np.ones((H, W, 1), np.float32)
    alpha[:3] = 0
    fg = alpha > 0
    ch = {"albedo": rng.random((H, W, 3)), "normal": n, "roughness": rng.random((H, W, 1)),
          "specular": rng.random((H, W, 1)), "depth": 1 + rng.random((H, W, 1)) * 700,
          "alpha": alpha}
    ch = {k: v.astype(np.float32) for k, v in ch.items()}
    bg = {"albedo": 0.0, "normal": 0.0, "roughness": 1.0, "specular": 0.5, "depth": 0.0}
    for k, v in bg.items():  # canonical background, as the loaders produce
        ch[k] = np.where(fg, ch[k], np.float32(v))
    ch["metallic"] = np.zeros((H, W, 1), np.float32)
    ch["ao"] = np.ones((H, W, 1), np.float32)
    return ImageGBuffer(channels=ch, fov_y=27.5)


def test_stack_exr_round_trip(tmp_path):
    g = _stack()
    path = tmp_path / "stack.exr"
    save_stack_exr(path, g, near=1.0, far=800.0)
    arr, names = read_image(path)
    assert arr.shape == (H, W, 12)
    # depth is normalised by appendix B.2 and replicated to the three coordinate channels
    d = g.channels["depth"][5, 5, 0]
    for c in ("coord.X", "coord.Y", "coord.Z"):
        assert arr[5, 5, names.index(c)] == pytest.approx((d - 1.0) / 799.0, rel=1e-6)
    back = load_stack_exr(path, fov_y=10.0)
    assert back.fov_y == pytest.approx(27.5)  # the attribute wins over the argument
    assert back.size == (W, H)
    for name, want in g.channels.items():
        if name == "specular":  # background pixels take the G-buffer background value
            want = np.where(g.channels["alpha"] > 0, want, CHANNEL_BACKGROUND["specular"])
        atol = 1e-4 if name == "depth" else 1e-6  # depth: float32 of (D - 1) / 799
        np.testing.assert_allclose(back.channels[name], want, atol=atol, err_msg=name)


def test_stack_exr_positional_channels_and_fov_argument(tmp_path):
    """A file from elsewhere: generic channel names, (x, y, z) coordinates, no fov attribute."""
    rng = np.random.default_rng(1)
    arr = rng.random((H, W, 12)).astype(np.float32)
    arr[:, :, 8:11] = np.float32([0.5, 0.5, 1.0])  # normal (0, 0, 1)
    arr[:, :, 11] = 1.0
    arr[:, :, 7] = 0.25
    path = tmp_path / "generic.exr"
    write_exr(path, arr, [f"c{i:02d}" for i in range(12)])
    g = load_stack_exr(path, fov_y=30.0, near=2.0, far=10.0)
    assert g.fov_y == 30.0
    np.testing.assert_allclose(g.channels["depth"], 2.0 + 0.25 * 8.0)
    np.testing.assert_allclose(g.channels["albedo"], arr[:, :, :3])
    np.testing.assert_allclose(g.channels["normal"][..., 2], 1.0)


def test_stack_exr_validation(tmp_path):
    bad = tmp_path / "eleven.exr"
    write_exr(bad, np.zeros((4, 4, 11), np.float32))
    with pytest.raises(InputError, match="eleven.exr.*11 channels"):
        load_stack_exr(bad, fov_y=30)
    nan = tmp_path / "nan.exr"
    arr = np.full((4, 4, 12), 0.5, np.float32)
    arr[1, 2, 9] = np.nan
    write_exr(nan, arr, [f"c{i:02d}" for i in range(12)])
    with pytest.raises(InputError, match="nan.exr.*normal.*NaN"):
        load_stack_exr(nan, fov_y=30)
    arr[1, 2, 9] = 0.5
    write_exr(nan, arr, [f"c{i:02d}" for i in range(12)])
    with pytest.raises(InputError, match="nan.exr.*no fov_y"):
        load_stack_exr(nan)


def _albedo_u8(w, h) -> np.ndarray:
    """8-bit sRGB albedo whose R, G and B differ everywhere: R rises left to right, G top to
    bottom, B is a constant 40 (a channel swap or a flipped axis changes every pixel)."""
    a = np.empty((h, w, 3), np.uint8)
    a[..., 0] = np.round(np.linspace(120, 250, w))[None, :]
    a[..., 1] = np.round(np.linspace(10, 90, h))[:, None]
    a[..., 2] = 40
    return a


def _normal_xyz(w, h) -> np.ndarray:
    """A bulge's unit normals, camera space (+X right, +Y up, +Z towards the camera): x from
    -0.6 at the left column to +0.6 at the right, y from +0.5 in the top row (row 0) to -0.5."""
    x = np.linspace(-0.6, 0.6, w)[None, :].repeat(h, 0)
    y = np.linspace(0.5, -0.5, h)[:, None].repeat(w, 1)
    return np.stack([x, y, np.sqrt(1.0 - x * x - y * y)], -1)


def _normal_u8(w, h) -> np.ndarray:
    return np.round((_normal_xyz(w, h) * 0.5 + 0.5) * 255).astype(np.uint8)


def _srgb_decode(u8: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1's sRGB decoding, written here (not the loader's srgb_to_linear)."""
    c = u8.astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _check_ffhq_gbuffer(g, w=W, h=H):
    """The loaded G-buffer of :func:`_write_ffhq`'s files, channel by channel, against the values
    written: linear albedo R, G, B each (8-bit sRGB decoded: float32 rounding, 1e-6), and the
    normal's x, y, z each (n = 2 u8 / 255 - 1 renormalised: the 8-bit step is 0.0078, the written
    unit normals come back within 0.005 of each component), with their signs where they must be
    (right columns +x, top rows +y)."""
    fg = g.channels["alpha"][..., 0] > 0
    albedo = _srgb_decode(_albedo_u8(w, h))
    for c, name in enumerate("RGB"):
        np.testing.assert_allclose(g.channels["albedo"][..., c][fg], albedo[..., c][fg],
                                   atol=1e-6, err_msg=f"albedo {name}")
    n = g.channels["normal"]
    decoded = _normal_u8(w, h).astype(np.float64) / 255.0 * 2.0 - 1.0
    decoded /= np.linalg.norm(decoded, axis=-1, keepdims=True)
    want = _normal_xyz(w, h)
    for c, name in enumerate("xyz"):
        np.testing.assert_allclose(n[..., c][fg], decoded[..., c][fg], atol=1e-6,
                                   err_msg=f"normal {name}")
        np.testing.assert_allclose(n[..., c][fg], want[..., c][fg], atol=0.005,
                                   err_msg=f"normal {name}")
    assert (n[:, -1, 0] > 0.5).all() and (n[0, fg[0], 1] > 0.4).all()
    assert (n[-1, fg[-1], 1] < -0.4).all()


def _write_ffhq(folder, size=(W, H), **overrides):
    folder.mkdir(exist_ok=True)
    w, h = size
    rng = np.random.default_rng(2)
    u8 = lambda a: np.clip(np.round(a * 255), 0, 255).astype(np.uint8)  # noqa: E731
    files = {
        "rgb.png": lambda p: write_png(p, u8(rng.random((h, w, 3)))),
        "albedo.png": lambda p: write_png(p, _albedo_u8(w, h)),
        "normal.png": lambda p: write_png(p, _normal_u8(w, h)),
        "roughness.png": lambda p: write_png(p, u8(np.full((h, w, 1), 0.4))),
        "specular.png": lambda p: write_png(p, u8(np.full((h, w, 1), 0.6))),
        "depth.exr": lambda p: write_exr(p, np.full((h, w, 1), 3.5, np.float32)),
        "mask.png": lambda p: write_png(p, u8(np.tile((np.arange(w) >= 4)[None, :, None],
                                                      (h, 1, 1)))),
        "env.exr": lambda p: write_exr(p, np.ones((4, 8, 3), np.float32)),
    }
    files.update(overrides)
    for name, writer in files.items():
        if writer is not None:
            writer(folder / name)
    (folder / "camera.json").write_text(json.dumps({"fov_y": 12.0}))
    return folder


def test_ffhq_folder(tmp_path):
    g = load_ffhq_pbr(_write_ffhq(tmp_path / "00001"))
    assert g.size == (W, H) and g.fov_y == 12.0
    assert g.environment.name == "env.exr"
    assert g.target.shape == (H, W, 3)
    fg = g.channels["alpha"][..., 0] > 0
    assert fg.sum() == (W - 4) * H and (g.channels["alpha"][fg] == 1).all()
    _check_ffhq_gbuffer(g)
    np.testing.assert_allclose(np.linalg.norm(g.channels["normal"][fg], axis=-1), 1, atol=1e-6)
    np.testing.assert_allclose(g.channels["depth"][fg], 3.5)
    np.testing.assert_allclose(g.channels["roughness"][fg], 102 / 255, atol=1e-6)
    np.testing.assert_allclose(g.channels["ao"], 1.0)
    # background takes the G-buffer background values
    assert (g.channels["depth"][~fg] == 0).all() and (g.channels["normal"][~fg] == 0).all()


@pytest.mark.parametrize("mutation", ["rgb_swap", "flip_normal_y", "flip_rows"])
def test_the_ffhq_check_fails_on_a_broken_loader(tmp_path, monkeypatch, mutation):
    """The channel-by-channel check above against deliberately broken PNG decoding: albedo and
    normal read as BGR (an RGB swap), the normal's y negated (a flipped axis), every image read
    upside down. Each is rejected (the constant grey albedo and flat normals the fixture had
    before passed all three)."""
    from viewer.geometry import imagespace

    real = imagespace.read_image

    def broken(path, *args, **kwargs):
        arr, names = real(path, *args, **kwargs)
        name = Path(path).name
        if mutation == "rgb_swap" and name in ("albedo.png", "normal.png"):
            arr = arr[..., ::-1].copy()
        elif mutation == "flip_normal_y" and name == "normal.png":
            arr = arr.copy()
            arr[..., 1] = 1.0 - arr[..., 1]
        elif mutation == "flip_rows":
            arr = arr[::-1].copy()
        return arr, names

    monkeypatch.setattr(imagespace, "read_image", broken)
    g = load_ffhq_pbr(_write_ffhq(tmp_path / "m"))
    with pytest.raises(AssertionError):
        _check_ffhq_gbuffer(g)


def test_ffhq_depth_png_is_denormalised(tmp_path):
    folder = _write_ffhq(tmp_path / "s", **{
        "depth.exr": None,
        "depth.png": lambda p: write_png(p, np.full((H, W, 1), 51, np.uint8))})
    g = load_ffhq_pbr(folder)
    fg = g.channels["alpha"][..., 0] > 0
    np.testing.assert_allclose(g.channels["depth"][fg], 1.0 + 0.2 * 799.0, rtol=1e-6)


def test_ffhq_validation(tmp_path):
    small = lambda p: write_png(p, np.full((H // 2, W // 2, 3), 128, np.uint8))  # noqa: E731
    with pytest.raises(InputError, match=r"normal.png.*8x6.*16x12"):
        load_ffhq_pbr(_write_ffhq(tmp_path / "a", **{"normal.png": small}))
    grey = lambda p: write_png(p, np.full((H, W, 1), 128, np.uint8))  # noqa: E731
    with pytest.raises(InputError, match=r"normal.png.*1 channels"):
        load_ffhq_pbr(_write_ffhq(tmp_path / "b", **{"normal.png": grey}))
    with pytest.raises(InputError, match=r"missing required channel 'albedo'"):
        load_ffhq_pbr(_write_ffhq(tmp_path / "c", **{"albedo.png": None}))
    nan_depth = np.full((H, W, 1), 3.0, np.float32)
    nan_depth[2, 3] = np.inf
    with pytest.raises(InputError, match=r"depth.exr.*NaN/Inf"):
        load_ffhq_pbr(_write_ffhq(tmp_path / "d",
                                  **{"depth.exr": lambda p: write_exr(p, nan_depth)}))


def test_ffhq_zero_normals_face_the_camera(tmp_path):
    normal = np.full((H, W, 3), (128, 128, 255), np.uint8)
    normal[5, 10] = (127, 127, 127)  # decodes to ~(-0.004, -0.004, -0.004): zero length
    folder = _write_ffhq(tmp_path / "z", **{"normal.png": lambda p: write_png(p, normal)})
    with pytest.warns(UserWarning, match="1 zero-length normals"):
        g = load_ffhq_pbr(folder)
    np.testing.assert_allclose(g.channels["normal"][5, 10], [0, 0, 1])


def test_view_dirs_match_camera():
    d = view_dirs_cs(8, 6, 40.0)
    cam = Camera(position=(0, 0, 0), target=(0, 0, -1), fov_y=40.0, size=(8, 6))
    np.testing.assert_allclose(d, cam.view_rays_ws(), atol=1e-7)
    assert d[0, 0, 0] < 0 and d[0, 0, 1] > 0 and (d[..., 2] < 0).all()  # row 0 is the top
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1, atol=1e-6)
