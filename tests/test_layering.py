"""The house rules of the package layout, checked by parsing the imports (no subprocess, nothing
imported): ``viewer`` is the torch-free runtime and imports neither ``learned`` nor ``relight``
nor torch; ``learned`` (torch side) may import ``viewer`` but not ``relight``; ``relight`` (the
commands) may import both. No module imports itself back through a chain of others - counting
imports inside functions too, which hide a cycle but do not remove it. ``learned.twins`` imports
only torch and itself: the GL side of every comparison is ``learned.parity``."""
from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("viewer", "learned", "relight", "shaders", "assets")
FORBIDDEN = {"viewer": ("learned", "relight", "torch"), "learned": ("relight",)}
# the twins are pure torch mirrors of the GLSL: nothing of the GL side, nor of the harness using them
FORBIDDEN_SUBPACKAGE = {"learned.twins": ("viewer", "learned.parity", "learned.train")}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            out[_module_name(path)] = path
    return out


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """Every module ``name`` imports (absolute names), anywhere in the file."""
    is_pkg = path.name == "__init__.py"
    base = name.split(".") if is_pkg else name.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                anchor = base[: len(base) - (node.level - 1)]
                mod = ".".join(anchor + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            found.add(mod)
            for alias in node.names:  # "from pkg import module" imports a module
                if f"{mod}.{alias.name}" in known:
                    found.add(f"{mod}.{alias.name}")
    return found


@functools.lru_cache(maxsize=1)
def _graph() -> dict[str, set[str]]:
    """The module graph (parsed once per session: no test changes it)."""
    mods = _modules()
    known = set(mods)
    graph = {}
    for name, path in mods.items():
        deps = set()
        for imp in _imports(name, path, known):
            # the deepest known module the import names (a symbol import names its module)
            parts = imp.split(".")
            while parts and ".".join(parts) not in known:
                parts.pop()
            if parts:
                dep = ".".join(parts)
                if dep != name and not name.startswith(dep + "."):  # a package's own __init__
                    deps.add(dep)
            else:
                deps.add(imp)  # third party: kept for the forbidden-import rule
        graph[name] = deps
    return graph


def _reach(graph: dict[str, set[str]], start: str) -> dict[str, str | None]:
    """Every module importing ``start`` loads, directly or through others (the closure over the
    module graph, with the packages each imported module sits in: importing ``a.b.c`` runs
    ``a/__init__`` and ``a/b/__init__``), each mapped to the module that imports it (``start``
    to None), so a chain can be shown."""
    via: dict[str, str | None] = {start: None}
    todo = [start]
    while todo:
        v = todo.pop()
        parts = v.split(".")
        parents = {".".join(parts[:i]) for i in range(1, len(parts))} & graph.keys()
        for w in sorted(graph.get(v, set()) | parents):
            if w not in via:
                via[w] = v
                todo.append(w)
    return via


def _chain(via: dict[str, str | None], end: str) -> str:
    out = [end]
    while via[out[-1]] is not None:
        out.append(via[out[-1]])
    return " -> ".join(reversed(out))


def _forbidden(graph: dict[str, set[str]]) -> list[str]:
    """The breaches of FORBIDDEN (direct imports: every internal module a layer imports is
    itself held to its own rule, so the direct rule is closed already) and of
    FORBIDDEN_SUBPACKAGE, transitively: a twin that reaches ``viewer`` through a module of
    ``learned`` that imports it breaks the rule as a direct import would."""
    bad = []
    for name, deps in graph.items():
        top = name.split(".")[0]
        for dep in deps:
            if dep.split(".")[0] in FORBIDDEN.get(top, ()):
                bad.append(f"{name} imports {dep}")
        for sub, banned in FORBIDDEN_SUBPACKAGE.items():
            if not (name == sub or name.startswith(sub + ".")):
                continue
            via = _reach(graph, name)
            hits = sorted(d for d in via if any(d == b or d.startswith(b + ".") for b in banned))
            if hits:
                bad.append(f"{name} loads {len(hits)} modules of {', '.join(banned)}, e.g. "
                           f"{_chain(via, hits[0])}")
    return sorted(bad)


def test_layers_import_only_downwards():
    bad = _forbidden(_graph())
    assert not bad, "upward imports:\n" + "\n".join(bad)


def test_the_twin_rule_is_transitive():
    """The rule catches a twin that reaches ``viewer`` only through another module (as
    ``learned.twins.neural`` did, through ``learned.neural.lighting``'s ``viewer.gl``), and a
    package ``__init__`` on the way; a rule over direct imports alone passed both."""
    graph = _graph()
    broken = {**graph, "learned.twins.neural": graph["learned.twins.neural"]
              | {"learned.neural.lighting"}}
    bad = _forbidden(broken)
    assert any(b.startswith("learned.twins.neural loads") and "learned.neural.lighting -> viewer"
               in b for b in bad), bad
    assert "viewer" in graph["learned.neural.lighting"] or any(
        d.startswith("viewer.") for d in graph["learned.neural.lighting"])
    via_init = {**graph, "learned.twins.brdf": graph["learned.twins.brdf"] | {"learned.x.y"},
                "learned.x": {"viewer.gl"}, "learned.x.y": set()}
    assert any(b.startswith("learned.twins.brdf loads") for b in _forbidden(via_init))


def test_no_import_cycles():
    graph = _graph()
    internal = {n: {d for d in deps if d in graph} for n, deps in graph.items()}
    # Tarjan's strongly connected components: any component of more than one module is a cycle
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(internal[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(internal):
        if v not in index:
            visit(v)
    assert not cycles, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in cycles)


def test_the_rules_see_real_imports():
    """The parser must find imports that exist, or the rules above would pass vacuously."""
    graph = _graph()
    assert "viewer.renderer" in graph["relight.cli"] or any(
        d.startswith("viewer") for d in graph["relight.cli"])
    assert "torch" in graph["learned.twins.brdf"]
    assert "viewer.scene.description" in graph["viewer.renderer"]


# ---- the rooms ----------------------------------------------------------------------------------
# viewer/ is grouped by domain (scene, environment, lighting, geometry, ...): each package's
# docstring says what it holds and, in a paragraph starting "Imports:", which other rooms of viewer
# it may import. The rule below holds the code to what the docstrings say.

def _room(module: str) -> str:
    """``viewer.scene.checks`` -> ``viewer.scene``; a top-level module is a room of its own."""
    parts = module.split(".")
    return ".".join(parts[:2])


def _rooms() -> list[Path]:
    return sorted(p for p in (ROOT / "viewer").iterdir() if (p / "__init__.py").is_file())


def _declared_imports(package: Path) -> set[str]:
    doc = ast.get_docstring(ast.parse((package / "__init__.py").read_text())) or ""
    paragraph = doc.split("Imports:", 1)[1].split("\n\n", 1)[0] if "Imports:" in doc else ""
    return {_room(name) for name in re.findall(r"viewer(?:\.\w+)+", paragraph)}


def test_every_room_says_what_it_holds_and_imports():
    missing = [str(p.relative_to(ROOT)) for p in _rooms() if "Imports:" not in (
        ast.get_docstring(ast.parse((p / "__init__.py").read_text())) or "")]
    assert not missing, f"package docstrings without an 'Imports:' paragraph: {missing}"
    undocumented = [name for name, path in _modules().items()
                    if path.name == "__init__.py" and not ast.get_docstring(
                        ast.parse(path.read_text()))]
    assert not undocumented, f"packages without a docstring: {undocumented}"


def test_rooms_import_only_what_their_docstrings_say():
    graph = _graph()
    bad = []
    for package in _rooms():
        room = f"viewer.{package.name}"
        allowed = _declared_imports(package) | {room}
        for name, deps in graph.items():
            if _room(name) != room:
                continue
            for dep in deps:
                if dep.startswith("viewer.") and _room(dep) not in allowed:
                    bad.append(f"{name} imports {dep} ({room}'s docstring does not name "
                               f"{_room(dep)})")
    assert not bad, "\n".join(sorted(bad))


def test_the_room_rule_sees_real_imports():
    """The rule above must see a room's imports, or it would pass vacuously."""
    assert _declared_imports(ROOT / "viewer" / "passes") >= {"viewer.gl", "viewer.gbuffer"}
    assert "viewer.environment.sun" in _graph()["viewer.environment.irradiance"]


MAX_MODULE_LINES = 400  # a module longer than this holds more than one job
MAX_RENDERER_LINES = 300  # the renderer only declares the frame; the rooms do the work


def test_modules_stay_small():
    long = {str(p.relative_to(ROOT)): n for p in _modules().values()
            if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"
    renderer = len((ROOT / "viewer" / "renderer.py").read_text().splitlines())
    assert renderer <= MAX_RENDERER_LINES, f"viewer/renderer.py has {renderer} lines"
