"""Shader assembly: includes, error locations mapped to real files, variants and the cache."""
import pytest

from viewer.errors import GLContextError, ShaderCompileError
from viewer.gl import Programs, assemble

BROKEN_LIB = "// line 1\nfloat ok_fn(float x) { return x; }\nfloat broken(float x) {\n    return x + vec3(1.0);\n}\n"


def test_includes_are_inlined_once_and_origins_tracked():
    src = assemble("entry", virtual={
        "entry": '#include "lib/common.glsl"\n#include "lib/common.glsl"\nvoid main() {}\n'})
    assert src.source.count("float saturate(") == 1
    line = next(i for i, l in enumerate(src.source.splitlines()) if "float saturate(" in l)
    assert src.origins[line][0] == "lib/common.glsl"
    assert src.source.startswith("#version 430 core\n")


def test_defines_are_prepended_sorted():
    src = assemble("entry", defines={"B": 2, "A": True, "C": 0.5}, virtual={"entry": "void main(){}"})
    lines = src.source.splitlines()
    assert lines[1:4] == ["#define A 1", "#define B 2", "#define C 0.5"]


def test_missing_include_names_the_including_file():
    with pytest.raises(ShaderCompileError, match=r'entry:2: cannot resolve #include "lib/nope.glsl"'):
        assemble("entry", virtual={"entry": '// x\n#include "lib/nope.glsl"\n'})


def test_compile_error_reports_real_file_and_line(programs):
    entry = ('#include "lib/common.glsl"\n#include "lib/fake_broken.glsl"\n'
             "layout(local_size_x = 1) in;\nvoid main() {}\n")
    with pytest.raises(ShaderCompileError) as err:
        programs.compute("entry.comp", virtual={"entry.comp": entry,
                                                "lib/fake_broken.glsl": BROKEN_LIB})
    msg = str(err.value)
    assert "lib/fake_broken.glsl:4" in msg and "\n" not in msg


def test_variants_are_cached_by_defines(ctx):
    programs = Programs(ctx)
    entry = {"k.comp": "layout(local_size_x = 1) in;\nvoid main() {\n#if FOO\n#endif\n}\n"}
    a = programs.compute("k.comp", defines={"FOO": 1}, virtual=entry)
    b = programs.compute("k.comp", defines={"FOO": 1}, virtual=entry)
    c = programs.compute("k.comp", defines={"FOO": 0}, virtual=entry)
    assert a is b and a is not c and len(programs) == 2


def test_missing_egl_is_one_line(monkeypatch):
    import moderngl

    from viewer.gl import context

    def boom(*a, **k):
        raise Exception("libEGL.so: cannot open shared object file\nmore detail")

    monkeypatch.setattr(moderngl, "create_context", boom)
    with pytest.raises(GLContextError) as err:
        context.create_context()
    msg = str(err.value)
    assert "cannot create a headless EGL" in msg and "libEGL.so" in msg and "\n" not in msg
