"""Synthetic datasets: the generator's layout, splits, targets, determinism and resumption, the
reader's errors, and image G-buffers as geometry."""
import shutil

import numpy as np
import pytest

from learned.data import DatasetError, list_samples, load_sample
from learned.data.generator import GeneratorConfig, generate
from tiny_dataset import TINY
from viewer.errors import InputError


def test_generator_layout_splits_and_targets(dataset):
    assert [len(list_samples(dataset, s)) for s in ("train", "val", "test")] == [8, 1, 1]
    s = load_sample(list_samples(dataset, "val")[0])
    assert s.size == (16, 16) and s.target.shape == (16, 16, 3)
    assert s.foreground().any() and np.isfinite(s.target).all()
    n = s.channels["normal"][s.foreground()]
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-4)


def test_generator_writes_the_unoccluded_teacher_target(dataset):
    """rgb_unoccluded (the teacher's phase-1 target, issue 14): the same render without AO, SSAO
    and indirect light, so it is never darker than rgb by more than MC noise and strictly brighter
    where the material AO (0.6-1.0 on every primitive) darkens the diffuse term."""
    for folder in list_samples(dataset, "train"):
        s = load_sample(folder)
        assert s.unoccluded is not None and s.unoccluded.shape == s.target.shape
        fg = s.foreground()
        assert s.unoccluded[fg].mean() > s.target[fg].mean(), folder.name


def test_generator_is_deterministic_and_resumable(dataset, tmp_path, ctx):
    from viewer.renderer import Renderer

    other = tmp_path / "again"
    shutil.copytree(dataset, other)
    victim = list_samples(other, "train")[2]
    shutil.rmtree(victim)
    (victim.parent / (victim.name + ".tmp")).mkdir()  # an interrupted write
    r = Renderer(ctx=ctx)
    try:
        res = generate(other, TINY, renderer=r, progress=False)
    finally:
        r.release()
    assert res == {"written": 1, "kept": 9, "root": str(other)}
    a = load_sample(list_samples(dataset, "train")[2])
    b = load_sample(victim)
    assert np.array_equal(a.target, b.target)
    for k in a.channels:
        assert np.array_equal(a.channels[k], b.channels[k]), k
    assert not (victim.parent / (victim.name + ".tmp")).exists()


def test_generator_refuses_another_config(dataset):
    with pytest.raises(DatasetError, match="another configuration"):
        generate(dataset, GeneratorConfig(count=10, size=32), progress=False)


def test_reader_errors_name_the_file(dataset, tmp_path):
    src = list_samples(dataset, "test")[0]
    bad = tmp_path / "s"
    shutil.copytree(src, bad)
    (bad / "rgb.exr").unlink()
    with pytest.raises(DatasetError, match="missing the target image"):
        load_sample(bad)
    (bad / "albedo.exr").unlink()
    with pytest.raises(InputError, match="missing required channel 'albedo'") as info:
        load_sample(bad)
    assert str(bad) in str(info.value)
    shutil.rmtree(bad)
    shutil.copytree(src, bad)
    from viewer.imageio import write_exr

    write_exr(bad / "roughness.exr", np.zeros((8, 16, 1), np.float32), ["Y"])
    with pytest.raises(InputError, match="size mismatch"):
        load_sample(bad)


# ---- image G-buffers as geometry --------------------------------------------------------------

IMAGE = GeneratorConfig(count=3, size=16, samples=4, seed=5, env_width=32, gbuffer_fraction=1.0)


def _generate(root, cfg, ctx):
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    try:
        return generate(root, cfg, renderer=r, progress=False)
    finally:
        r.release()


def test_image_gbuffer_samples_are_deterministic_resumable_and_varied(tmp_path, ctx):
    import json

    root = tmp_path / "img"
    assert _generate(root, IMAGE, ctx)["written"] == 3
    folders = list_samples(root, "train")
    for f in folders:
        meta = json.loads((f / "meta.json").read_text())
        assert meta["geometry"]["kind"] == "gbuffer" and meta["objects"][0]["type"] == "gbuffer"
        assert not (f / "_source").exists()
        s = load_sample(f)
        fg = s.foreground()
        assert fg.sum() > 10 and np.isfinite(s.target).all() and s.target[fg].max() > 0
    # per-pixel materials: one rendered object (one material) became a spatially varying field
    s = load_sample(folders[0])
    assert s.channels["roughness"][s.foreground()].std() > 0.02
    before = {k: v.copy() for k, v in s.channels.items()} | {"rgb": s.target.copy()}
    shutil.rmtree(folders[0])
    (folders[0].parent / (folders[0].name + ".tmp")).mkdir()
    assert _generate(root, IMAGE, ctx) == {"written": 1, "kept": 2, "root": str(root)}
    again = load_sample(folders[0])
    for k, v in again.channels.items():
        assert np.array_equal(v, before[k]), k
    assert np.array_equal(again.target, before["rgb"])


def test_image_gbuffer_from_a_12_channel_stack(dataset, tmp_path, ctx):
    from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr

    src = load_sample(list_samples(dataset, "val")[0])
    stack = tmp_path / "stack.exr"
    save_stack_exr(stack, ImageGBuffer(channels=src.channels, fov_y=src.fov_y))
    cfg = GeneratorConfig(count=1, size=16, samples=4, seed=1, env_width=32,
                          gbuffer_fraction=1.0, gbuffers=(str(stack),))
    _generate(tmp_path / "d", cfg, ctx)
    out = load_sample(list_samples(tmp_path / "d", "train")[0])
    fg = out.foreground()
    assert np.array_equal(fg, src.foreground())  # the stack's geometry ...
    assert np.allclose(out.channels["normal"][fg], src.channels["normal"][fg], atol=1e-3)
    # ... with new materials
    assert not np.allclose(out.channels["albedo"][fg], src.channels["albedo"][fg])


def test_datasets_from_before_the_gbuffer_options_still_resume(dataset, tmp_path, ctx):
    import json

    other = tmp_path / "old"
    shutil.copytree(dataset, other)
    info = json.loads((other / "dataset.json").read_text())
    for k in ("gbuffer_fraction", "gbuffers"):
        info["config"].pop(k)
    (other / "dataset.json").write_text(json.dumps(info))
    assert _generate(other, TINY, ctx)["kept"] == 10


def test_a_lambertian_ground_makes_the_sky_as_bright_below_as_its_albedo():
    """``lambertian_ground``: the upper hemisphere untouched, the lower one uniform, and a
    surface facing down lit by albedo x what lights one facing up (``env_below`` within 0.04 of
    the albedo, measured within 0.003: the soft horizon band keeps a little sky), on the
    procedural sky with its sun and without (its own dark ground: 0.07 and 0.18)."""
    from learned.data.generator.config import GeneratorConfig as Config
    from learned.data.generator.environments import lambertian_ground, random_environment
    from viewer.environment.irradiance import env_below, irradiance_map
    from viewer.environment.maps import sky_environment, texel_directions

    for sun in (2000.0, 0.0):
        sky = sky_environment(128, sun_radiance=sun)
        y = texel_directions(128)[..., 1]
        assert env_below(irradiance_map(sky, 128)) < 0.2
        for albedo in (0.3, 0.8):
            env = lambertian_ground(sky, albedo)
            np.testing.assert_array_equal(env[y > 0], sky[y > 0])
            below = env[y < -0.125]
            assert np.ptp(below, axis=0).max() < 1e-5 * below.max()
            assert env_below(irradiance_map(env, 128)) == pytest.approx(albedo, abs=0.04)
    # the generator's share: 0 draws no ground (the draws of before), 1 a ground every time
    rng = lambda: np.random.default_rng(5)  # noqa: E731
    plain, recipe = random_environment(rng(), Config(env_width=64))
    assert "ground_albedo" not in recipe
    grounded, recipe = random_environment(rng(), Config(env_width=64, ground_fraction=1.0))
    assert 0.2 <= recipe["ground_albedo"] <= 0.9
    assert not np.allclose(plain, grounded)
    from learned.data.generator.config import check_config

    with pytest.raises(DatasetError, match="ground_fraction"):
        check_config(Config(count=1, ground_fraction=2.0))
