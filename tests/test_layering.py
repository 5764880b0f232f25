"""The house rules of the package layout, checked by parsing the imports (no subprocess, nothing
imported): ``viewer`` is the torch-free runtime and imports neither ``learned`` nor ``relight``
nor torch; ``learned`` (torch side) may import ``viewer`` but not ``relight``; ``relight`` (the
commands) may import both. No module imports itself back through a chain of others - counting
imports inside functions too, which hide a cycle but do not remove it. ``learned.twins`` imports
only torch and itself: the GL side of every comparison is ``learned.parity``."""
from __future__ import annotations

import ast
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


def _graph() -> dict[str, set[str]]:
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


def test_layers_import_only_downwards():
    bad = []
    for name, deps in _graph().items():
        top = name.split(".")[0]
        for dep in deps:
            if dep.split(".")[0] in FORBIDDEN.get(top, ()):
                bad.append(f"{name} imports {dep}")
            for sub, banned in FORBIDDEN_SUBPACKAGE.items():
                if (name == sub or name.startswith(sub + ".")) and any(
                        dep == b or dep.startswith(b + ".") for b in banned):
                    bad.append(f"{name} imports {dep}")
    assert not bad, "upward imports:\n" + "\n".join(sorted(bad))


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
    assert "viewer.scene" in graph["viewer.renderer"]
