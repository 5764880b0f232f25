"""The base colour a mesh's maps give is the texture's, without isolated wrong texels.

llvmpipe (Mesa 22.3) read texels from elsewhere in the texture wherever ``textureGrad`` met a
sampler with anisotropic filtering: the plasma gun under lobby at 160 x 120 had 54 dark 2 x 2
quads on its rim in every model's image (its unlit albedo at 0.02-0.12 where the map reads
0.4-0.6 at those uv, found against the path-traced reference; 2026-11-29), and stray emissive
dots in its barrel. ``sample_map`` now reads non-mirrored maps with ``texture()`` and a mirrored
map's sampler drops its anisotropy on llvmpipe (``viewer/passes/mesh_uploads.py``)."""
from pathlib import Path

import numpy as np
import pytest


def _dark_specks(albedo: np.ndarray, fg: np.ndarray) -> int:
    """Covered pixels whose albedo (the mean of RGB) is under 0.4 x their 3 x 3 median."""
    from scipy.ndimage import median_filter

    lum = albedo[..., :3].mean(-1)
    return int(((lum < 0.4 * median_filter(lum, 3)) & fg).sum())


def test_the_gun_has_no_wrong_texels(ctx):
    """The gun's unlit albedo: 8 dark pixels against their neighbours (its real dark detail;
    54 before the fix, on this driver), under 16 asserted. On a driver without the fault both
    are the same image."""
    from relight.bench.real_assets import asset_scene
    from viewer.renderer import Renderer

    scene = asset_scene("cge_plasma_gun/plasma.gltf",
                        Path(__file__).parents[2] / "assets" / "environments" / "lobby.exr",
                        (160, 120))
    r = Renderer(ctx=ctx)
    try:
        f = r.render(scene.with_render(model="unlit"), aovs=("albedo", "alpha"))
    finally:
        r.release()
    fg = f.aovs["alpha"][..., 0] > 0.5
    assert fg.sum() > 10000  # the gun fills the frame
    assert _dark_specks(f.aovs["albedo"], fg) < 16


def test_only_a_mirrored_sampler_drops_anisotropy_on_llvmpipe(ctx):
    """``sample_map`` takes ``textureGrad`` only for a mirrored wrap, so only that sampler gives
    up anisotropic filtering, and only on the software rasteriser."""
    from viewer.geometry.mesh import TextureSampling
    from viewer.gl.context import is_software
    from viewer.passes.mesh_uploads import ANISOTROPY, SOFTWARE_MIRROR_ANISOTROPY, MeshUploads

    uploads = MeshUploads(ctx, program=None)  # samplers only: no mesh is drawn
    try:
        plain = uploads._sampler(TextureSampling())
        mirror = uploads._sampler(TextureSampling(wrap=("mirror", "repeat")))
        assert plain.anisotropy == pytest.approx(ANISOTROPY)
        want = SOFTWARE_MIRROR_ANISOTROPY if is_software(ctx) else ANISOTROPY
        assert mirror.anisotropy == pytest.approx(want)
    finally:
        uploads.release()
