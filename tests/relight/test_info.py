"""``relight info``: the GLSL version is the driver's own string (moderngl's ``ctx.info`` has no
``GL_SHADING_LANGUAGE_VERSION``, which printed ``glsl: None``), and where it cannot be read the
line says why instead of ``None``."""
import json
import re

from relight.cli import main


def _glsl_matches_gl(glsl: str, version_code: int) -> bool:
    # GL 3.3 and later: the GLSL version is the GL version ("4.50" for 450), maybe with a suffix
    m = re.match(r"(\d+)\.(\d+)", glsl)
    return m is not None and int(m[1]) * 100 + int(m[2]) == version_code


def test_gl_info_reads_the_glsl_version(ctx):
    from viewer.gl import gl_info
    from viewer.gl.context import glsl_version

    version = glsl_version(ctx)
    assert isinstance(version, str) and _glsl_matches_gl(version, ctx.version_code)
    assert gl_info(ctx)["glsl"] == version


def test_info_prints_the_glsl_version(capsys):
    assert main(["info", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert _glsl_matches_gl(info["glsl"], info["version_code"])
    assert main(["info"]) == 0
    lines = [ln.strip() for ln in capsys.readouterr().out.splitlines()]
    assert f"glsl: {info['glsl']}" in lines


def test_info_says_why_the_glsl_version_is_unknown(capsys, monkeypatch):
    import viewer.gl

    real = viewer.gl.gl_info
    monkeypatch.setattr(viewer.gl, "gl_info", lambda ctx: {**real(ctx), "glsl": None})
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "None" not in out
    assert "glsl: unknown (GL_SHADING_LANGUAGE_VERSION could not be read" in out
