"""Shader assembly and the program cache.

A program is built from entry files in ``shaders/passes/`` (or generated text) that ``#include``
pure-function files from ``shaders/lib/``. :func:`assemble` inlines includes once each (include
guards are implicit) and records which file and line every output line came from, so a driver
message such as Mesa's ``0:57(3): error`` is reported as ``lib/brdf.glsl:12(3)``. (``#line`` with a
source-string number would be neater, but Mesa ignores the number, so we map global lines.) Variants are prepended
``#define`` lines; the compiled program is cached under (stages, defines).

The cache is bounded by count (:attr:`viewer.cache.Budgets.programs`, least recently used first):
an evicted program is released at once, with whatever was registered on it (:func:`on_release`:
the vertex arrays made for it), and a later request compiles it again. Look a program up where it
is used (every pass does, per draw) rather than keeping it: what was looked up inside
:meth:`Programs.frame` is never evicted before that frame ends.
"""
from __future__ import annotations

import re
import weakref
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable, Mapping

from shaders import SHADER_ROOT

from ..cache import BoundedCache, Budgets, CacheStats
from ..errors import ShaderCompileError

GLSL_VERSION = "#version 430 core"
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
# Mesa: "0:12(3): error: ...", NVIDIA: "0(12) : error ...", AMD/Intel: "ERROR: 0:12: ..."
_LOCATION = re.compile(r"\b(\d+)(?::(\d+)\((\d+)\)|\((\d+)\)|:(\d+))")


@dataclass
class Assembled:
    """GLSL text plus, for every output line, the file and line it came from."""

    source: str
    origins: list[tuple[str, int]] = field(default_factory=list)  # [output line - 1] -> (file, line)

    def where(self, message: str) -> str:
        """Rewrite driver locations (``0:57(5)``) in ``message`` as ``lib/brdf.glsl:12(5)``."""

        def repl(m: re.Match) -> str:
            line = int(m.group(2) or m.group(4) or m.group(5))
            if not 1 <= line <= len(self.origins):
                return m.group(0)
            name, original = self.origins[line - 1]
            col = f"({m.group(3)})" if m.group(3) else ""
            return f"{name}:{original}{col}"

        return _LOCATION.sub(repl, message)


def _format_define(name: str, value) -> str:
    if value is True or value is None:
        return f"#define {name} 1"
    if value is False:
        return f"#define {name} 0"
    if isinstance(value, float):
        return f"#define {name} {value!r}"
    return f"#define {name} {value}"


def assemble(entry: str, defines: Mapping[str, object] | None = None,
             virtual: Mapping[str, str] | None = None) -> Assembled:
    """Assemble ``entry`` (a path under ``shaders/`` or a key of ``virtual``) into one GLSL string.

    ``virtual`` maps include names to generated text (for example the G-buffer layout or an exported
    network); they are resolved before files on disk and reported under their own names.
    """
    virtual = dict(virtual or {})
    out = Assembled(source="")
    lines = [GLSL_VERSION] + [_format_define(k, v) for k, v in sorted((defines or {}).items())]
    out.origins = [("<defines>", i + 1) for i in range(len(lines))]
    seen: set[str] = set()

    def read(name: str, parent: str | None, parent_line: int) -> str:
        if name in virtual:
            return virtual[name]
        path = SHADER_ROOT / name
        if not path.is_file():
            origin = f"{parent}:{parent_line}: " if parent else ""
            raise ShaderCompileError(f"{origin}cannot resolve #include \"{name}\"", where="shaders")
        return path.read_text()

    def emit(name: str, parent: str | None = None, parent_line: int = 0) -> None:
        if name in seen:
            return
        seen.add(name)
        text = read(name, parent, parent_line)
        for number, line in enumerate(text.splitlines(), start=1):
            m = _INCLUDE.match(line)
            if m:
                emit(m.group(1), name, number)
                continue
            if line.lstrip().startswith("#version"):
                line = ""  # the assembler owns the version line
            lines.append(line)
            out.origins.append((name, number))

    emit(entry)
    out.source = "\n".join(lines) + "\n"
    return out


class _ReleaseHooks:
    """What to call when :class:`Programs` releases a program (kept in the program's ``extra``):
    weak references, so a pass that is gone is not kept alive by the programs it used."""

    def __init__(self):
        self.refs: list = []

    def add(self, callback: Callable[[object], None]) -> None:
        self.refs = [r for r in self.refs if r() is not None]  # what died meanwhile
        if not any(r() == callback for r in self.refs):
            self.refs.append(weakref.WeakMethod(callback) if hasattr(callback, "__self__")
                             else weakref.ref(callback))

    def run(self, program) -> None:
        refs, self.refs = self.refs, []
        for ref in refs:
            callback = ref()
            if callback is not None:
                callback(program)


def on_release(program, callback: Callable[[object], None]) -> None:
    """Call ``callback(program)`` just before :class:`Programs` releases ``program`` (evicted from
    the cache, or the cache released): drop what was made for it, such as vertex arrays. Held
    weakly (a bound method of an object that is gone is skipped); a program that did not come
    from :class:`Programs` is never released by it, so nothing is registered."""
    hooks = getattr(program, "extra", None)
    if isinstance(hooks, _ReleaseHooks):
        hooks.add(callback)


def _release_program(program) -> None:
    hooks = getattr(program, "extra", None)
    if isinstance(hooks, _ReleaseHooks):
        hooks.run(program)
    program.release()


class Programs:
    """Compiles and caches programs for one context, keyed by stages, defines and virtual files;
    at most ``max_items`` (least recently used evicted and released; ``None``: unbounded)."""

    def __init__(self, ctx, max_items: int | None = Budgets.programs):
        self.ctx = ctx
        self._cache = BoundedCache("programs", max_items=max_items, release=_release_program)

    def _key(self, stages, defines, virtual):
        return (stages, tuple(sorted((defines or {}).items())),
                tuple(sorted((virtual or {}).items())))

    def graphics(self, vertex: str, fragment: str, defines: Mapping[str, object] | None = None,
                 virtual: Mapping[str, str] | None = None):
        """A vertex + fragment program (cached)."""

        def build():
            defs = dict(defines or {})
            vs = assemble(vertex, {**defs, "STAGE_VERTEX": 1}, virtual)
            fs = assemble(fragment, {**defs, "STAGE_FRAGMENT": 1}, virtual)
            try:
                prog = self.ctx.program(vertex_shader=vs.source, fragment_shader=fs.source)
            except Exception as exc:
                raise self._error(exc, fragment, (vs, fs)) from None
            prog.extra = _ReleaseHooks()
            return prog

        return self._cache.get_or_create(self._key(("vf", vertex, fragment), defines, virtual),
                                         build)

    def compute(self, entry: str, defines: Mapping[str, object] | None = None,
                virtual: Mapping[str, str] | None = None):
        """A compute program (cached)."""

        def build():
            cs = assemble(entry, {**dict(defines or {}), "STAGE_COMPUTE": 1}, virtual)
            try:
                prog = self.ctx.compute_shader(cs.source)
            except Exception as exc:
                raise self._error(exc, entry, (cs,)) from None
            prog.extra = _ReleaseHooks()
            return prog

        return self._cache.get_or_create(self._key(("c", entry), defines, virtual), build)

    @staticmethod
    def _error(exc: Exception, entry: str, parts) -> ShaderCompileError:
        text = str(exc)
        # moderngl names the failing stage ("vertex_shader", "fragment_shader", "compute_shader").
        part = parts[0] if ("vertex_shader" in text and len(parts) > 1) else parts[-1]
        mapped = part.where(text)
        errors = [ln.strip() for ln in mapped.splitlines() if "error" in ln.lower() and ":" in ln]
        detail = "; ".join(dict.fromkeys(e for e in errors if not e.startswith("GLSL Compiler")))
        return ShaderCompileError(detail or mapped.strip().splitlines()[-1], where=entry)

    @contextmanager
    def frame(self):
        """``with programs.frame():`` around a frame: no program looked up inside is evicted
        before it ends (the count may exceed the budget meanwhile)."""
        with self._cache.frame():
            yield self

    def resize(self, max_items: int | None) -> None:
        """A new count budget (evicting at once what no longer fits)."""
        self._cache.resize(max_items=max_items)

    def stats(self) -> CacheStats:
        return self._cache.stats()

    def release(self) -> None:
        """Release every program (and what was registered on them: :func:`on_release`)."""
        self._cache.clear()

    def __contains__(self, program) -> bool:
        """Whether ``program`` (the object) is cached now."""
        return any(p is program for p in self._cache.values())

    def __len__(self) -> int:
        return len(self._cache)
