"""glTF alphaMode in the path-traced reference (relight/reference/scene.py ``_opacity``): MASK
cuts the surface where the (bilinearly read) base colour alpha is below alphaCutoff, as the
rasteriser's alpha test does, for camera rays and shadow rays alike; BLEND covers a fraction
alpha of the samples; OPAQUE ignores alpha and traces as it always did."""
import math

import numpy as np
from reference_quad import quad_gltf
from relight.reference import ReferenceOptions, render_reference
from viewer.scene.description import scene_from_dict

BLACK = {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}
# 4 x 4 RGBA, white: alpha 1 in columns 0-1 (u < 0.5), 0 in columns 2-3; clamped sampling, so
# bilinear alpha falls linearly from 1 at u = 0.375 to 0 at u = 0.625
LEFT_HALF = np.concatenate([np.full((4, 2, 4), 255, np.uint8),
                            np.dstack([np.full((4, 2, 3), 255, np.uint8),
                                       np.zeros((4, 2, 1), np.uint8)])], axis=1)


def _quad(path, material: dict, rgba=None, extra: dict | None = None):
    """A 1 x 1 quad at z = 0 facing +Z (u along +x) with ``material``; ``rgba`` (8-bit) becomes
    its base colour texture (clamp-to-edge); ``extra``: more material keys (alphaMode ...)."""
    mat = {"pbrMetallicRoughness": dict(material), "doubleSided": True, **(extra or {})}
    return quad_gltf(path, mat, rgba, "baseColorTexture", {"wrapS": 33071, "wrapT": 33071})


def _front(path, background="transparent", size=16):
    """The quad filling the view (fov 25 deg at distance 2: +-0.44 of it), white sky behind."""
    return scene_from_dict({
        "camera": {"position": [0.0, 0.0, 2.0], "target": [0.0, 0.0, 0.0], "fov_y": 25,
                   "size": [size, size]},
        "environment": {"procedural": "white", "width": 32},
        "render": {"multiscatter": False, "ao": False, "tonemap": "none",
                   "background": background},
        "objects": [{"type": "mesh", "path": str(path)}]})


def test_mask_cuts_where_the_interpolated_alpha_is_below_the_cutoff(mitsuba_llvm, renderer,
                                                                   tmp_path):
    """alphaCutoff 0.25 on LEFT_HALF: the bilinear alpha crosses 0.25 at u = 0.5625, between
    the centres of columns 8 (u = 0.528, alpha 0.39) and 9 (u = 0.583, alpha 0.17) of 16. A
    per-texel threshold would cut at u = 0.5 (column 8 through). The reference's coverage equals
    the rasteriser's alpha test pixel for pixel (exact: MASK coverage is 0 or 1 per sample),
    and the sky is seen through the cut-out part only."""
    path = _quad(tmp_path / "mask.gltf", BLACK, LEFT_HALF,
                 {"alphaMode": "MASK", "alphaCutoff": 0.25})
    scene = _front(path)
    ref = render_reference(scene, ReferenceOptions(spp=4, max_depth=2), progress=False)
    cover = ref.radiance[..., 3]
    assert np.all(cover[:, :9] == 1.0) and np.all(cover[:, 9:] == 0.0), cover[0]
    ours = renderer.render(scene.with_render(model="ggx_split_sum", raytrace=False)).radiance
    np.testing.assert_array_equal(cover, ours[..., 3])
    # opaque background: the white sky (radiance 1) behind the cut, a black dielectric in
    # front of it elsewhere (its F0 = 0.04 reflection of the sky: ~0.04-0.1, never near 1)
    seen = render_reference(_front(path, "environment"), ReferenceOptions(spp=4, max_depth=2),
                            progress=False).radiance[..., :3]
    np.testing.assert_allclose(seen[:, 9:], 1.0, rtol=1e-5)
    assert seen[:, :9].max() < 0.2, seen[:, :9].max()


def test_mask_coverage_on_the_scalar_backend(mitsuba_llvm, tmp_path):
    """The scalar backend's coverage walk through cut-outs (a ray that passes the quad and
    misses everything has no BSDF to ask: it crashed before): 8 x 8, alphaCutoff 0.25, cut from
    u = 0.5625 (columns 5-7, centres at u >= 0.67; column 4's at 0.56 stays)."""
    path = _quad(tmp_path / "mask.gltf", BLACK, LEFT_HALF,
                 {"alphaMode": "MASK", "alphaCutoff": 0.25})
    ref = render_reference(_front(path, size=8), ReferenceOptions(spp=1, max_depth=2,
                                                                  variant="scalar_rgb"),
                           progress=False)
    assert ref.meta["variant"] == "scalar_rgb"
    cover = ref.radiance[..., 3]
    assert np.all(cover[:, :5] == 1.0) and np.all(cover[:, 5:] == 0.0), cover[0]


def test_mask_cut_outs_let_shadow_rays_through(mitsuba_llvm, tmp_path):
    """A directional light straight down through a horizontal LEFT_HALF quad (cutoff 0.5) onto
    a white floor, seen from above past the quad's edge: the floor under the opaque half is in
    shadow (0), under the cut-out half lit as if the quad were absent (E / pi x albedo, exact
    with a delta light and max_depth 2). Mitsuba's ``path`` integrator would shadow both."""
    path = _quad(tmp_path / "leaf.gltf", BLACK, LEFT_HALF, {"alphaMode": "MASK"})
    scene = scene_from_dict({
        "camera": {"position": [0.0, 3.0, 1e-3], "target": [0.0, 0.0, 0.0], "fov_y": 8,
                   "size": [16, 16]},
        "environment": {"procedural": "white", "intensity": 0.0, "width": 32},
        "render": {"multiscatter": False, "ao": False, "tonemap": "none"},
        "lights": [{"type": "directional", "direction": [0.0, 1.0, 0.0], "intensity": 2.0}],
        "objects": [
            {"type": "mesh", "path": str(path),  # lying flat at y = 0.5 (x along u)
             "transform": [[1, 0, 0, 0], [0, 0, 1, 0.5], [0, -1, 0, 0], [0, 0, 0, 1]]},
            {"type": "plane", "center": [0, 0, 0], "size": [4, 4],
             "material": {"albedo": [1, 1, 1], "specular": 0.0}}]})
    ref = render_reference(scene, ReferenceOptions(spp=8, max_depth=2), progress=False)
    rad = ref.radiance[..., 0]
    # the view (+-4 deg: +-0.18 at the quad) lies inside the quad (+-0.5); image right is +x:
    # the opaque half (x < 0) hides the floor, through the cut-out half (x > 0) it is lit.
    # rtol: float32 rounding of the delta light's single exact sample
    np.testing.assert_allclose(rad[:, 9:], 2.0 / math.pi, rtol=1e-4)
    # the black quad: only its dielectric GGX highlight of the light (F0 0.04, rough 0.5: ~0.1)
    assert np.all(rad[:, :7] < 0.2), rad[:, :7].max()


def test_blend_covers_alpha_of_the_samples(mitsuba_llvm, tmp_path):
    """BLEND at baseColorFactor alpha 0.5: each sample hits the quad with probability 0.5, so a
    pixel's coverage over 256 samples is 0.5 +- 0.031 (binomial standard error) and the mean
    of 256 pixels 0.5 +- 0.002; bounds at 5 standard errors. The radiance (opaque background)
    is 0.5 x sky + 0.5 x the black quad's reflection (0.04-0.1): between 0.5 and 0.6."""
    factor = dict(BLACK, baseColorFactor=[0.0, 0.0, 0.0, 0.5])
    path = _quad(tmp_path / "blend.gltf", factor, extra={"alphaMode": "BLEND"})
    ref = render_reference(_front(path), ReferenceOptions(spp=256, max_depth=2), progress=False)
    cover = ref.radiance[..., 3]
    assert np.all(np.abs(cover - 0.5) < 5 * 0.5 / 16), (cover.min(), cover.max())
    assert abs(cover.mean() - 0.5) < 5 * 0.5 / 16 / 16, cover.mean()
    seen = render_reference(_front(path, "environment"), ReferenceOptions(spp=256, max_depth=2),
                            progress=False).radiance[..., :3].mean()
    assert 0.5 - 5 * 0.5 / 16 / 16 < seen < 0.6, seen


def test_opaque_ignores_alpha_and_traces_as_before(mitsuba_llvm, tmp_path):
    """OPAQUE with a map whose alpha is 0 on half the quad: no ``mask`` wrapper, Mitsuba's
    ``path`` integrator, and the very image (same seed) of the same map without alpha."""
    from relight.reference.scene import to_mitsuba

    mi, dr, _ = mitsuba_llvm
    with_alpha = _front(_quad(tmp_path / "a.gltf", BLACK, LEFT_HALF), "environment")
    rgb = _front(_quad(tmp_path / "b.gltf", BLACK, LEFT_HALF[..., :3]), "environment")
    desc = to_mitsuba(with_alpha, mi, dr, 2)
    assert desc["integrator"]["type"] == "path"
    assert "Mask" not in str(desc["shape_0"].bsdf())
    opts = ReferenceOptions(spp=4, max_depth=2, seed=3)
    a = render_reference(with_alpha, opts, progress=False).radiance
    b = render_reference(rgb, opts, progress=False).radiance
    np.testing.assert_array_equal(a, b)


def test_cache_keys_change_with_alpha_tracing_only_for_scenes_with_alpha(tmp_path, monkeypatch):
    """Cached truths (relight.gallery.panels.cached_truth) are keyed by config_key: a scene whose
    glTF (.gltf or .glb) declares MASK or BLEND is keyed by how alpha is traced, so truths traced
    before (opaque) are not reused; an OPAQUE scene's key does not depend on it."""
    import struct

    from relight.reference import keys, scene as ref_scene

    mask = _front(_quad(tmp_path / "m.gltf", BLACK, LEFT_HALF, {"alphaMode": "MASK"}))
    opaque = _front(_quad(tmp_path / "o.gltf", BLACK, LEFT_HALF))
    doc = (tmp_path / "m.gltf").read_bytes()
    doc += b" " * (-len(doc) % 4)  # the JSON chunk padded to 4 bytes with spaces
    (tmp_path / "m.glb").write_bytes(b"glTF" + struct.pack("<II", 2, 20 + len(doc))
                                     + struct.pack("<II", len(doc), 0x4E4F534A) + doc)
    glb = _front(tmp_path / "m.glb")
    assert ref_scene.alpha_modes(mask) == ["MASK"] == ref_scene.alpha_modes(glb)
    assert ref_scene.alpha_modes(opaque) == []
    opts = ReferenceOptions()
    before = [keys.config_key(s, opts) for s in (mask, glb, opaque)]
    monkeypatch.setattr(keys, "ALPHA_TRACING", keys.ALPHA_TRACING + 1)
    after = [keys.config_key(s, opts) for s in (mask, glb, opaque)]
    assert before[0] != after[0] and before[1] != after[1] and before[2] == after[2]
