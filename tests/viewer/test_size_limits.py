"""A frame size beyond the GL limits or the machine's memory is one :class:`SceneError` naming the
size and the limit, raised before any target is allocated (the renderer's pool stays empty); the
CLI prints it as one line with status 2 and writes nothing; a normal size renders."""
import pytest

from relight.cli import main
from viewer.errors import SceneError
from viewer.scene.description import Material, ObjectSpec, Scene

SPHERE = """
[camera]
position = [0, 0, 3]
size = [24, 20]
[environment]
procedural = "white"
[[objects]]
type = "sphere"
"""


@pytest.fixture(scope="module")
def renderer():
    from viewer.renderer import Renderer

    r = Renderer()
    yield r
    r.release()


def _scene(**render) -> Scene:
    scene = Scene(objects=(ObjectSpec(type="sphere", material=Material()),))
    return scene.with_render(**render) if render else scene


def _pool_items(renderer) -> int:
    return renderer.resources.pool.stats().items


def test_size_above_the_gl_maximum_is_one_error_and_allocates_nothing(renderer):
    from viewer.renderer import Renderer

    fresh = Renderer(ctx=renderer.ctx)  # its own pool, empty
    limit = int(fresh.ctx.info["GL_MAX_TEXTURE_SIZE"])
    with pytest.raises(SceneError) as err:
        fresh.render(_scene(), size=(limit + 1, 8))
    msg = str(err.value)
    assert msg.startswith("--size: ") and f"{limit + 1}x8" in msg and str(limit) in msg
    assert "GL_MAX_" in msg and "\n" not in msg
    assert _pool_items(fresh) == 0


def test_ssaa_counts_against_the_limit(renderer):
    limit = int(renderer.ctx.info["GL_MAX_TEXTURE_SIZE"])
    side = limit // 2 + 1
    with pytest.raises(SceneError, match=rf"{side}x8 x ssaa 2 = {2 * side}x16 .* lower ssaa"):
        renderer.draw(_scene(ssaa=2), size=(side, 8))


def test_a_scene_files_size_is_named_as_its_camera_size(renderer, tmp_path):
    from viewer.scene.description import load_scene

    p = tmp_path / "big.toml"
    limit = int(renderer.ctx.info["GL_MAX_TEXTURE_SIZE"])
    side = limit // 8 + 1  # within the scene files' 16384, beyond the limit at ssaa 8
    p.write_text(SPHERE.replace("[24, 20]", f"[8, {side}]") + "[render]\nssaa = 8\n")
    with pytest.raises(SceneError, match=rf"big.toml: camera.size: size 8x{side} x ssaa 8"):
        renderer.draw(load_scene(p))


def test_size_beyond_available_memory_is_one_error(renderer, monkeypatch):
    from viewer import frame as display
    from viewer.renderer import Renderer

    fresh = Renderer(ctx=renderer.ctx)
    monkeypatch.setattr(display, "available_memory", lambda: 1000)  # 1000 bytes left
    with pytest.raises(SceneError, match=r"--size: size 64x64 needs at least .* GiB .* memory "
                                         r"available; render smaller"):
        fresh.render(_scene(), size=(64, 64))
    assert _pool_items(fresh) == 0


def test_available_memory_is_a_positive_number_here():
    from viewer.frame import available_memory

    free = available_memory()
    assert free is None or free > 0


def test_a_normal_size_renders(renderer):
    frame = renderer.render(_scene(), size=(32, 24))
    assert frame.radiance.shape[:2] == (24, 32)


def test_cli_prints_one_line_status_2_and_writes_nothing(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(SPHERE)
    out = tmp_path / "x.png"
    # 16384 x ssaa 8 = 131072 pixels a side: beyond any GL's texture size
    assert main(["render", str(scene), "--out", str(out), "--size", "16384x16384",
                 "--ssaa", "8"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("relight: error: --size: size 16384x16384 x ssaa 8") and "\n" not in err
    assert "limit" in err and not out.exists() and list(tmp_path.iterdir()) == [scene]


def test_software_renderer_texture_bytes(renderer, tmp_path, capsys):
    """llvmpipe takes 16384 a side but no texture over 2 GiB: --size 16384x16384 (a 4 GiB
    RGBA32F radiance) is one line, not "framebuffer is not complete"."""
    if "llvmpipe" not in str(renderer.ctx.info["GL_RENDERER"]).lower():
        pytest.skip("a Mesa software renderer's limit")
    scene = tmp_path / "s.toml"
    scene.write_text(SPHERE)
    out = tmp_path / "x.png"
    assert main(["render", str(scene), "--out", str(out), "--size", "16384x16384"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("relight: error: --size: size 16384x16384 needs 4.0 GiB")
    assert "2 GiB a texture" in err and "\n" not in err and not out.exists()
