"""The architecture page (``explanation/architecture.md``), generated from the code at every build:
the rooms of each package (their docstrings' first paragraph and modules), the imports between
the rooms of ``viewer`` (parsed from the source, drawn as a Mermaid graph), and where each job
lives (each answer a module or package that must exist, so a move that breaks one fails the build)."""
from __future__ import annotations

import ast
import re
from pathlib import Path

from common import _esc

ROOT = Path(__file__).resolve().parents[2]

# "Where is ...?" -> the module that answers it. Each must exist: the page cannot name a room
# that does not exist.
WHERE = (
    ("a scene file is read into dataclasses", "viewer.scene.description"),
    ("a `[render]` key is checked", "viewer.scene.checks"),
    ("the `[render]` settings are grouped", "viewer.scene.settings"),
    ("an asset opened without a scene file is framed and turned upright",
     "viewer.scene.assets"),
    ("an HDR map is loaded or a procedural sky made", "viewer.environment.maps"),
    ("the sun and other compact lights are extracted", "viewer.environment.sun"),
    ("the split-sum IBL is prefiltered", "viewer.environment.prefilter"),
    ("the environment is importance-sampled", "viewer.environment.sampling"),
    ("the environment disk cache lives", "viewer.environment.disk_cache"),
    ("punctual lights are described", "viewer.lighting.lights"),
    ("a shadow map's frame is fitted", "viewer.lighting.shadow_frames"),
    ("shadow cascades are split", "viewer.lighting.cascades"),
    ("the G-buffer layout is declared", "viewer.gbuffer"),
    ("a frame's passes are declared", "viewer.graph.frame"),
    ("the shading models are registered", "viewer.models"),
    ("a glTF file is read", "viewer.geometry.loaders.gltf"),
    ("the BVH rays traverse is built", "viewer.raytrace.bvh"),
    ("the real-time tier's rays are declared in the frame", "viewer.graph.raytrace"),
    ("a GLSL function's torch twin lives", "learned.twins"),
    ("GLSL and torch are compared", "learned.parity"),
    ("the path-traced reference is rendered", "relight.reference.render"),
)


def _doc(path: Path) -> str:
    return ast.get_docstring(ast.parse(path.read_text())) or ""


def _first_paragraph(doc: str) -> str:
    """The docstring's first paragraph as Markdown: Sphinx roles and ``literals`` as code spans."""
    text = " ".join(doc.split("\n\n", 1)[0].split())
    text = re.sub(r":\w+:`~?\.?([^`]+)`", r"`\1`", text)
    return text.replace("``", "`")


def _modules(package: Path) -> list[str]:
    return sorted(p.stem if p.is_file() else p.name + "/" for p in package.iterdir()
                  if (p.suffix == ".py" and p.name != "__init__.py")
                  or (p / "__init__.py").is_file())


def _room_of(name: str) -> str:
    return ".".join(name.split(".")[:2])


def _viewer_room_imports() -> dict[str, set[str]]:
    """viewer room -> the other viewer rooms its modules import (relative imports resolved)."""
    out: dict[str, set[str]] = {}
    for path in sorted((ROOT / "viewer").rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        package = parts[:-1]
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        room = _room_of(name)
        deps = out.setdefault(room, set())
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    anchor = package[: len(package) - (node.level - 1)]
                    mod = ".".join(anchor + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                targets = [mod] + [f"{mod}.{a.name}" for a in node.names] if mod == "viewer" \
                    else [mod]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            for t in targets:
                if t.startswith("viewer.") and _room_of(t) != room:
                    dep = _room_of(t)
                    if (ROOT / dep.replace(".", "/")).is_dir() or \
                            (ROOT / (dep.replace(".", "/") + ".py")).is_file():
                        deps.add(dep)
    return out


def _rooms_table(package: str) -> list[str]:
    root = ROOT / package
    out = ["| room | what it holds | modules |", "|---|---|---|"]
    for path in sorted(p for p in root.iterdir() if (p / "__init__.py").is_file()):
        out.append(f"| `{package}/{path.name}/` | {_esc(_first_paragraph(_doc(path / '__init__.py')))}"
                   f" | {_esc(', '.join(_modules(path)))} |")
    tops = sorted(p for p in root.glob("*.py") if p.name != "__init__.py")
    for path in tops:
        out.append(f"| `{package}/{path.name}` | {_esc(_first_paragraph(_doc(path)))} | |")
    return out


def _mermaid(edges: dict[str, set[str]]) -> list[str]:
    packages = {r for r in edges if (ROOT / r.replace(".", "/")).is_dir()}
    out = ["```mermaid", "graph LR"]
    for room in sorted(edges):
        short = room.split(".", 1)[1] if "." in room else room
        shape = f'{short}["{short}/"]' if room in packages else f'{short}("{short}")'
        out.append(f"  {shape}")
    for room, deps in sorted(edges.items()):
        a = room.split(".", 1)[1] if "." in room else room
        for dep in sorted(deps):
            if dep in ("viewer.errors", "viewer.cache"):  # imported by nearly every room
                continue
            out.append(f"  {a} --> {dep.split('.', 1)[1]}")
    out.append("```")
    return out


def architecture_markdown() -> str:
    where = []
    for question, module in WHERE:
        path = module.replace(".", "/")
        path = path + "/" if (ROOT / path).is_dir() else path + ".py"
        if not (ROOT / path).exists():  # a room that moved or vanished fails the build
            raise FileNotFoundError(f"architecture page: {module} ({path}) does not exist")
        where.append(f"| {question} | `{path}` |")
    edges = _viewer_room_imports()
    edges.pop("viewer", None)
    out = [
        "# Architecture", "",
        "<!-- generated by docs/_hooks/architecture.py from the packages' docstrings and "
        "imports -->", "",
        "Three packages, each a layer: `viewer` is the torch-free runtime (GL context, scene, "
        "passes, renderer); `learned` is the torch side (twins, parity, datasets, training) and "
        "may import `viewer`; `relight` holds the commands, the benchmarks and the interactive "
        "viewer and may import both. GLSL lives in `shaders/` (`lib/`: pure functions, each "
        "with a torch twin in `learned/twins/`; `passes/`: one entry point per pass in "
        "`viewer/passes/`). `tests/test_layering.py` holds the code to every rule on this page.",
        "",
        "## Where is ...?", "",
        "| where ... | room |", "|---|---|", *where, "",
        "## The rooms of `viewer`", "",
        "One domain a folder; at the top the renderer, the frame it produces, the model registry "
        "and what every room shares. Each package's docstring says what it may import; the "
        "arrows below are the imports the code really makes (`errors` and `cache`, which nearly "
        "every room imports, left out).", "",
        *_mermaid(edges), "",
        *_rooms_table("viewer"), "",
        "## A frame's data flow", "",
        "A scene file (or asset files) becomes frozen dataclasses (`scene/`); the renderer asks "
        "`specialize` what the scene requires and `graph/frame.py` declares the passes of that "
        "frame; the frame graph culls what nobody reads, reuses what did not change and hands "
        "each pass its targets from a bounded pool. Geometry comes from `geometry/` (meshes, "
        "primitives, image stacks) and `splats/`, light from `environment/` (IBL, compact lights, "
        "sampling tables) and `lighting/` (punctual lights, shadow frames), programs from `gl/`. "
        "The passes (`passes/`) write the G-buffer, the shadow maps, occlusion, radiance and the "
        "display image, which `frame.py` reads back.", "",
        "```mermaid", "graph LR",
        '  S["scene/"] --> R("renderer") --> G["graph/"]',
        '  G --> P["passes/"]',
        '  GE["geometry/ + splats/"] --> P',
        '  E["environment/"] --> P',
        '  L["lighting/"] --> P',
        '  P --> F("frame: radiance, display, AOVs")',
        "```", "",
        "The passes of the demo scene's frame, as `relight graph --dot` draws them:", "",
        "![The demo's frame graph](graph/demo.svg)", "",
        "## The rooms of `learned`", "",
        *_rooms_table("learned"), "",
        "## The rooms of `relight`", "",
        *_rooms_table("relight"), "",
    ]
    return "\n".join(out) + "\n"
