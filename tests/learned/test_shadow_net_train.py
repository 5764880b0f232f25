"""Training the neural shadow estimator (learned/train/shadow_net.py) on the tiny dataset: the
loss falls, the weights file the viewer reads records what it was trained on and its validation
score, and a run resumes from its checkpoint."""
import numpy as np
import pytest
import torch

from learned.neural.shadow_net import ShadowNet, load_shadow_net
from learned.train.shadow_net import (
    ShadowNetImage,
    ShadowNetTrainConfig,
    augmented,
    loss,
    shadow_net_images,
    train_shadow_net,
)
from viewer.neural.shadow_net import read_shadow_net


@pytest.fixture
def one_thread():
    """torch on one thread: on two cores shared with GL and other workers its thread pool is
    ~50x slower (measured 1 s against 20 ms a step)."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def test_the_estimator_trains_resumes_and_records_its_data(dataset, tmp_path, ctx, one_thread,
                                                           capsys):
    """30 steps lower the training loss over the training images (the default log MSE,
    measured: -4.50 -> -4.75, the MSE 22 % lower; the bound asks for 10 %)."""
    from viewer.renderer import Renderer

    cfg = ShadowNetTrainConfig(data=str(dataset), out=str(tmp_path / "run"), steps=30, batch=3,
                               lr=1e-3, log_every=10, checkpoint_every=10, limit=4,
                               degrade_levels=())  # (none written beside the shared fixture)
    res = train_shadow_net(cfg, quiet=True)
    losses = res["losses"]
    r = Renderer(ctx=ctx)
    try:
        images = shadow_net_images(str(dataset), "train", r, limit=4, indirect=cfg.indirect)
    finally:
        r.release()
    torch.manual_seed(cfg.seed)
    with torch.no_grad():
        terms = (cfg.visibility_target, cfg.loss, cfg.linear_weight, cfg.energy_weight)
        before = float(loss(ShadowNet(cfg.architecture), images, *terms))
        after = float(loss(load_shadow_net(res["shadow_net"]), images, *terms))
        print(f"training loss {before:.3f} -> {after:.3f}")
    # the default loss is a mean log MSE (negative): the images' MSE falls by more than 10 %
    assert cfg.loss == "log_mse" and len(losses) == 30
    assert after < before + np.log(0.9), (before, after)
    net = read_shadow_net(res["shadow_net"])
    assert len(net.training["dataset_hash"]) == 64 and net.training["steps"] == 30
    assert set(net.training["val_psnr"]) == {"with", "without"}
    assert all(np.isfinite(v) for v in net.training["val_psnr"].values())
    more = train_shadow_net(ShadowNetTrainConfig(**{**cfg.__dict__, "steps": 34}), quiet=True)
    assert len(more["losses"]) == 34 and more["losses"][:30] == losses
    assert "resuming at step 30/34" in (tmp_path / "run" / "train.log").read_text()
    # relight info --weights tells where the file came from
    import json

    from relight.cli import main

    capsys.readouterr()
    assert main(["info", "--weights", res["shadow_net"], "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["kind"] == "shadow_net" and row["receptive_field_px"] == 220
    assert row["dataset_hash"] == net.training["dataset_hash"] and "val_psnr" in row


def test_the_inputs_are_the_frames_with_the_targets_in_its_row_order(dataset, ctx):
    """The unshadowed frame matches its own target better than the target upside down (the
    dataset's images are top row first, the frame's GL targets bottom row first)."""
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    try:
        images = shadow_net_images(str(dataset), "train", r, limit=4)
    finally:
        r.release()
    for img in images:
        assert img.inputs.shape[1] == 9 and img.surface.any()
        m = img.surface.expand(-1, 3, -1, -1)
        same = (img.radiance[:, :3] - img.target).abs()[m].mean()
        flipped = (img.radiance[:, :3] - img.target.flip(-2)).abs()[m].mean()
        assert same < flipped, (img.name, float(same), float(flipped))
        assert torch.isfinite(img.inputs).all()


def test_augmentation_keeps_the_best_visibility_and_mirrors_the_normals():
    """Exposure and tint multiply radiance and target alike (target / radiance unchanged), the
    radiance input follows the radiance, and a mirrored image has its normals' x negated."""
    g = torch.Generator().manual_seed(0)
    rad = torch.rand(1, 4, 6, 5, generator=g) + 0.1
    inputs = torch.rand(1, 9, 6, 5, generator=g)
    img = ShadowNetImage("a", rad, inputs, torch.rand(1, 1, 6, 5, generator=g) > 0.3,
                         torch.rand(1, 3, 6, 5, generator=g), torch.rand(1, 3, 6, 5, generator=g))
    rng = np.random.default_rng(0)
    seen = set()
    for _ in range(8):
        out = augmented(img, rng, 0.2)
        flipped = not torch.equal(out.surface, img.surface)
        seen.add(flipped)
        ref = img if not flipped else ShadowNetImage(
            "a", rad.flip(-1), inputs.flip(-1), img.surface.flip(-1), img.target.flip(-1),
            img.albedo.flip(-1))
        assert torch.equal(out.albedo, ref.albedo)  # the base colour moves with the pixels
        ratio = out.target / out.radiance[:, :3]
        assert torch.allclose(ratio, ref.target / ref.radiance[:, :3], rtol=1e-5)
        assert not torch.allclose(out.radiance[:, :3], ref.radiance[:, :3])
        assert torch.allclose(out.inputs[:, :3], torch.log1p(out.radiance[:, :3]), atol=1e-6)
        assert torch.equal(out.radiance[:, 3:], ref.radiance[:, 3:])
        sign = -1.0 if flipped else 1.0
        assert torch.equal(out.inputs[:, 4], sign * ref.inputs[:, 4])
        assert torch.equal(out.inputs[:, 3], ref.inputs[:, 3])
    assert seen == {True, False}


def test_decals_paint_frame_target_and_base_colour_alike_on_the_surfaces():
    """A decal multiplies radiance, target and base colour by one pattern on the surfaces only
    (target / radiance unchanged, the background untouched), darkening some surface pixels by
    at least 20 % (the least contrast), the radiance input recomputed; every kind of pattern is
    drawn, and each is a factor in (0, 1]."""
    from learned.train.decals import KINDS, decal
    from learned.train.shadow_net import decaled

    g = torch.Generator().manual_seed(1)
    rad = torch.rand(1, 4, 40, 48, generator=g) + 0.1
    surface = torch.rand(1, 1, 40, 48, generator=g) > 0.3
    img = ShadowNetImage("a", rad, torch.rand(1, 9, 40, 48, generator=g), surface,
                         torch.rand(1, 3, 40, 48, generator=g), torch.rand(1, 3, 40, 48,
                                                                           generator=g))
    rng = np.random.default_rng(0)
    for _ in range(8):
        out = decaled(img, rng)
        f = out.radiance[:, :3] / rad[:, :3]
        assert torch.allclose(out.target / img.target, f, rtol=1e-5)
        assert torch.allclose(out.albedo / img.albedo, f, rtol=1e-5)
        assert torch.equal(f[~surface.expand_as(f)], torch.ones_like(f[~surface.expand_as(f)]))
        assert float(f.min()) <= 0.8 + 1e-6 and float(f.max()) <= 1.0 + 1e-6
        assert torch.allclose(out.inputs[:, :3], torch.log1p(out.radiance[:, :3]), atol=1e-6)
        assert torch.equal(out.inputs[:, 3:], img.inputs[:, 3:])
    rng = np.random.default_rng(1)
    drawn = [decal(rng, 32, 32) for _ in range(40)]
    assert all(float(d.min()) > 0.0 and float(d.max()) <= 1.0 for d in drawn)
    assert len(KINDS) == 4 and len({d.numpy().tobytes() for d in drawn}) == 40


def test_a_demodulating_estimator_reads_the_radiance_over_the_base_colour():
    """``"demodulate"``: the estimator's radiance input is log(1 + L / max(albedo, 0.05)), in
    training (:func:`model_inputs`) as in the torch model, so a texture in the albedo that the
    radiance carries too leaves the input flat; without it the input follows the texture."""
    from learned.neural.shadow_net import ShadowNet
    from learned.train.shadow_net import model_inputs, shaded
    from learned.twins.shadow_net import shadow_net_inputs

    g = torch.Generator().manual_seed(3)
    light = torch.rand(1, 3, 8, 8, generator=g) * 0.1 + 1.0  # smooth light, ~1
    albedo = torch.where(torch.rand(1, 3, 8, 8, generator=g) > 0.5, 0.8, 0.1)  # a texture
    albedo[..., 0, 0] = 0.01  # under the floor: divided by 0.05
    rad = torch.cat([light * albedo, torch.ones(1, 1, 8, 8)], 1)
    ao, depth, vis = (torch.rand(1, 1, 8, 8, generator=g) for _ in range(3))
    normal = torch.nn.functional.normalize(torch.rand(1, 3, 8, 8, generator=g) - 0.5, dim=1)
    inputs = shadow_net_inputs(rad, ao, normal, depth, vis)
    img = ShadowNetImage("a", rad, inputs, torch.ones(1, 1, 8, 8, dtype=torch.bool),
                         torch.rand(1, 3, 8, 8, generator=g), albedo)
    arch = {"levels": 2, "widths": [4, 4]}
    plain, demod = ShadowNet(arch), ShadowNet({**arch, "demodulate": True})
    assert not plain.demodulates and demod.demodulates
    assert torch.equal(model_inputs(plain, img), inputs)
    x = model_inputs(demod, img)
    expect = torch.log1p(light * albedo / albedo.clamp_min(0.05))
    assert torch.allclose(x[:, :3], expect, atol=1e-6) and torch.equal(x[:, 3:], inputs[:, 3:])
    assert float(x[:, :3].std()) < 0.5 * float(inputs[:, :3].std())  # the texture is gone
    demod.load_state_dict(plain.state_dict())
    with torch.no_grad():
        v = demod.visibility(rad, ao, normal, depth, vis, albedo=albedo)
        assert torch.allclose(shaded(demod, img)[:, :3], rad[:, :3] * v, atol=1e-6)
        assert not torch.allclose(v, plain.visibility(rad, ao, normal, depth, vis), atol=1e-4)
        with pytest.raises(ValueError, match="give the albedo"):
            demod.visibility(rad, ao, normal, depth, vis)


def test_extra_datasets_join_the_training_images(dataset, tmp_path, ctx, one_thread):
    """``extra_data``: another dataset's train split trains too (here the same one again: twice
    the images), and its hash goes into the weights' metadata."""
    cfg = ShadowNetTrainConfig(data=str(dataset), out=str(tmp_path / "run"), steps=2, batch=2,
                               limit=2, extra_data=(str(dataset),), degrade_levels=())
    res = train_shadow_net(cfg, quiet=True)
    assert "4 training images" in (tmp_path / "run" / "train.log").read_text()
    net = read_shadow_net(res["shadow_net"])
    assert net.training["extra_data_hashes"] == [net.training["dataset_hash"]]


def test_degraded_copies_and_more_val_sets(dataset, tmp_path, ctx, one_thread):
    """``degrade_levels``: one level doubles the training images (the train split again with
    degraded G-buffers: other inputs, the same targets), its hash and level in the metadata;
    ``val_data``: another dataset's val split scored with and without the estimator, in the
    summary and in the metadata under its name."""
    import shutil

    data = tmp_path / "d"  # a copy: the degraded data is written beside the shared fixture's
    shutil.copytree(dataset, data)
    cfg = ShadowNetTrainConfig(data=str(data), out=str(tmp_path / "run"), steps=2, batch=2,
                               limit=2, degrade_levels=(0.5,), val_data=(str(dataset),))
    res = train_shadow_net(cfg, quiet=True)
    log = (tmp_path / "run" / "train.log").read_text()
    assert "4 training images (1 degraded sets)" in log, log
    assert (data / "_degraded" / "0.5" / "train").is_dir()
    (sc,) = res["val_data"].values()
    assert set(res["val_data"]) == {str(dataset)} and set(sc) == {"with", "without"}
    # the same val split as data's own: the same scores
    assert sc["without"]["psnr"] == pytest.approx(res["val"]["without"]["psnr"], abs=1e-9)
    assert sc["with"]["psnr"] == pytest.approx(res["val"]["with"]["psnr"], abs=1e-6)
    t = read_shadow_net(res["shadow_net"]).training
    assert t["degrade_levels"] == [0.5] and len(t["degraded_data_hashes"]) == 1
    assert t["degraded_data_hashes"][0] != t["dataset_hash"]
    entry = t["val_data"][str(dataset)]
    assert entry["with"] == pytest.approx(sc["with"]["psnr"]) and len(entry["dataset_hash"]) == 64
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    try:
        plain = shadow_net_images(str(data), "train", r, limit=2)
        worse = shadow_net_images(str(data / "_degraded" / "0.5"), "train", r, limit=2)
    finally:
        r.release()
    for a, b in zip(plain, worse):
        assert a.name == b.name and torch.equal(a.target, b.target)
        assert not torch.equal(a.inputs, b.inputs)


def test_cli_options_set_the_config(dataset, tmp_path, monkeypatch, capsys):
    """``relight train --stage shadow_net``'s --shadow-* options reach ShadowNetTrainConfig (an
    omitted one keeps the field's default); a bad value is one line naming the option."""
    import learned.train.shadow_net as mod
    from relight.cli import main

    seen = []
    monkeypatch.setattr(mod, "train_shadow_net", lambda cfg, quiet=False: seen.append(cfg) or {
        "shadow_net": "x", "val": {}, "val_data": {}})
    base = ["train", "--stage", "shadow_net", "--data", str(dataset), "--out",
            str(tmp_path / "run"), "-q"]
    assert main(base + ["--shadow-extra-data", str(dataset), str(dataset), "--shadow-val-data",
                        str(dataset), "--shadow-degrade", "0.25,1", "--shadow-geometry",
                        "stack", "--shadow-energy", "1", "--shadow-linear", "0.5",
                        "--shadow-decals", "0.5", "--shadow-prior", "0.3"]) == 0
    assert main(base + ["--shadow-geometry", "mesh"]) == 0
    assert main(base) == 0
    given, mesh, default = seen
    assert given.extra_data == (str(dataset),) * 2 and given.val_data == (str(dataset),)
    assert given.degrade_levels == (0.25, 1.0) and given.geometry == "stack"
    assert given.energy_weight == 1.0 and given.linear_weight == 0.5 and given.decals == 0.5
    assert given.prior_weight == 0.3 and default.prior_weight == 0.0
    assert default.decals == 0.0
    assert mesh.geometry == "mesh" and mod.levels(mesh) == ()
    assert mod.levels(default) == mod.DEFAULT_DEGRADE_LEVELS  # stacks: degraded copies
    assert main(base + ["--shadow-degrade", "none"]) == 0 and seen.pop().degrade_levels == ()
    ref = ShadowNetTrainConfig(data=str(dataset), out=str(tmp_path / "run"))
    assert default == ref
    # S(x) by the geometry: stacks read it, meshes not (the shipped files); the option decides
    assert mod.architecture(default)["env_visibility"] is True
    assert mod.architecture(mesh)["env_visibility"] is False
    assert main(base + ["--shadow-geometry", "mesh", "--shadow-env-visibility"]) == 0
    assert mod.architecture(seen.pop())["env_visibility"] is True
    assert main(base + ["--no-shadow-env-visibility"]) == 0
    assert mod.architecture(seen.pop())["env_visibility"] is False
    # architecture keys over the shipped design (--shadow-arch), with the S(x) option or without
    assert main(base + ["--shadow-arch", '{"upsample": "bilinear", "demodulate": true}',
                        "--no-shadow-env-visibility"]) == 0
    arch = mod.architecture(seen.pop())
    assert arch == mod.SHIPPED_ARCHITECTURE | {"upsample": "bilinear", "demodulate": True,
                                               "env_visibility": False}
    # meshes with degraded copies: their degraded stacks, the meshes casting (test_mesh_geometry)
    assert main(base + ["--shadow-geometry", "mesh", "--shadow-degrade", "0.5"]) == 0
    assert mod.levels(seen.pop()) == (0.5,)
    capsys.readouterr()
    for flag, args in (("--shadow-degrade", ["--shadow-degrade", "0"]),
                       ("--shadow-degrade", ["--shadow-degrade", "0.5,1.5"]),
                       ("--shadow-degrade", ["--shadow-degrade", "half"]),
                       ("--shadow-energy", ["--shadow-energy", "-1"]),
                       ("--shadow-linear", ["--shadow-linear", "nan"]),
                       ("--shadow-prior", ["--shadow-prior", "-0.1"]),
                       ("--shadow-decals", ["--shadow-decals", "1.5"]),
                       ("--shadow-val-data", ["--shadow-val-data", str(tmp_path)]),
                       ("--shadow-arch", ["--shadow-arch", "{upsample: bilinear}"]),
                       ("--shadow-arch", ["--shadow-arch", '["bilinear"]']),
                       ("--shadow-arch", ["--shadow-arch", '{"upsample": "cubic"}']),
                       ("--shadow-arch", ["--shadow-arch", '{"gain": 9}']),
                       ("--shadow-arch", ["--shadow-arch", '{"env_visibility": true}'])):
        assert main(base + args) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"relight: error: {flag}: ") and err.count("\n") == 1, err
    argv = ["train", "--stage", "teacher", "--data", str(dataset), "--shadow-degrade", "0.5"]
    assert main(argv) == 2
    assert "--shadow-degrade" in capsys.readouterr().err and len(seen) == 3


def test_the_frame_it_multiplies_is_recorded_scored_and_checked(dataset, tmp_path, ctx,
                                                                one_thread):
    """``indirect``: the frames carry the one-bounce indirect light (more light, never less, on
    the surfaces); the weights record it (``frame``), the protocol draws their frames from it and
    refuses files trained on different frames, and the viewer warns when a scene's frame is not
    the one the file was trained on."""
    import warnings
    from types import SimpleNamespace

    from learned.data.reader import DatasetError
    from learned.protocol.shadow_net import weights_frame
    from viewer.neural.shadow_net import frame_settings
    from viewer.graph.shadow_net import check_frame
    from viewer.renderer import Renderer
    from viewer.scene.settings import RenderSettings

    r = Renderer(ctx=ctx)
    try:
        plain = shadow_net_images(str(dataset), "train", r, limit=2)
        lit = shadow_net_images(str(dataset), "train", r, limit=2, indirect=True)
    finally:
        r.release()
    for a, b in zip(plain, lit):
        m = a.surface.expand(-1, 3, -1, -1)
        extra = (b.radiance[:, :3] - a.radiance[:, :3])[m]
        # the indirect light only adds (float32 rounding: 1e-5 of the radiance)
        assert extra.min() > -1e-5 * float(a.radiance[:, :3].abs().max()) and extra.sum() > 0
    files = {}
    for ind in (False, True):
        cfg = ShadowNetTrainConfig(data=str(dataset), out=str(tmp_path / f"r{ind}"), steps=2,
                                   batch=2, limit=2, indirect=ind, degrade_levels=())
        files[ind] = train_shadow_net(cfg, quiet=True)["shadow_net"]
        assert frame_settings(read_shadow_net(files[ind]).training)["indirect"] is ind
    assert frame_settings({})["indirect"] is False  # files written before the record
    assert weights_frame([files[True]])["indirect"] is True
    with pytest.raises(DatasetError) as info:
        weights_frame([files[True], files[False]])
    assert "\n" not in str(info.value) and files[False] in str(info.value)
    # specular occlusion: in the frames of the shipped recipe, not in those of files before it
    assert frame_settings(read_shadow_net(files[True]).training)["specular_occlusion"] is True
    assert frame_settings({})["specular_occlusion"] is False
    net = SimpleNamespace(path=files[True], training=read_shadow_net(files[True]).training)
    off = {"ssao": True, "specular_occlusion": False}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_frame(net, RenderSettings().with_flat(ssao=True, indirect=True))  # the default
        assert not caught
        check_frame(net, RenderSettings().with_flat(ssao=True, indirect=False))
        check_frame(net, RenderSettings().with_flat(indirect=True, **off))
        check_frame(net, RenderSettings().with_flat(indirect=False, **off))
    said = [str(c.message) for c in caught]
    assert len(said) == 3 and "set indirect = true" in said[0], said
    assert "set specular_occlusion = true" in said[1] and "indirect" not in said[1], said
    assert "set indirect = true specular_occlusion = true" in said[2], said
