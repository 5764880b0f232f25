"""``relight graph [SCENE.toml]``: the frame graph of a scene, as the renderer runs it.

Prints every pass (drawn, reused or culled, and why), every resource (descriptor, bytes, kept or
transient, first and last pass using it) and the renderer's caches. ``--then KEY=VALUE`` draws
the first frame, applies a ``[render]`` change (a slider: ``exposure=1.5``, ``light_intensity=2``,
``ssao_radius=0.8``...) and prints the second frame's graph, so it shows what that change redraws
and why. ``--dot FILE`` writes the graph as Graphviz DOT (``dot -Tpng FILE -o graph.png``),
``--json`` prints it as JSON.
"""
from __future__ import annotations

import json
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from viewer.cache import mib
from viewer.errors import SceneError


def add_parser(sub) -> None:
    p = sub.add_parser("graph", help="print a scene's frame graph: passes, resources, reuse",
                       description=__doc__.split("\n\n")[1])
    p.add_argument("scene", nargs="?", help="scene TOML (default: the built-in demo)")
    p.add_argument("--size", help="WxH (overrides [camera] size)")
    p.add_argument("--model", help="shading model (overrides [render] model)")
    p.add_argument("--then", action="append", default=[], metavar="KEY=VALUE",
                   help="a [render] change after a first frame (repeatable): show what it redraws")
    p.add_argument("--dot", help="write the graph as Graphviz DOT to this file")
    p.add_argument("--json", action="store_true", help="print the graph as JSON")
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    p.set_defaults(func=cmd_graph)


def parse_change(text: str) -> tuple[str, object]:
    """``KEY=VALUE`` with a TOML value (``exposure=1.5``, ``model="neural"``, ``ssao=true``); a
    bare word is taken as a string."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise SceneError(f"expected KEY=VALUE, got {text!r}", where="--then")
    try:
        parsed = tomllib.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value.strip()
    return key.strip(), parsed


def cmd_graph(args) -> int:
    from viewer.renderer import Renderer
    from viewer.scene.description import load_scene, validate_render

    from .commands import _context_options, _demo_path, _parse_size

    scene = load_scene(args.scene or _demo_path())
    if args.model:
        validate_render({"model": args.model}, "--model")
        scene = scene.with_render(model=args.model)
    changes = dict(parse_change(t) for t in args.then)
    for key, value in changes.items():  # checked as a scene file's [render] is
        validate_render({key: value}, f"--then {key}")
    size = _parse_size(args.size) if args.size else None
    dot = Path(args.dot) if args.dot else None
    if dot is not None and not dot.resolve().parent.is_dir():
        raise SceneError("output folder does not exist", where=dot.parent)

    renderer = Renderer(options=_context_options(args))
    try:
        if changes:
            renderer.draw(scene, size)
            scene = scene.with_render(**changes)
        renderer.draw(scene, size)
        graph = renderer.last_graph
        memory = {name: s.as_dict() for name, s in renderer.memory().items()}
    finally:
        renderer.release()
    info = graph.describe()
    info["memory"] = memory
    info["scene"] = str(scene.source or "scene")
    info["then"] = {k: v for k, v in changes.items()}
    if dot is not None:
        dot.write_text(graph.to_dot())
    if args.json:
        print(json.dumps(info, indent=2, default=str))
    else:
        print(format_graph(info))
        if dot is not None:
            print(f"wrote {dot}")
    return 0


def format_graph(info: dict) -> str:
    """The text ``relight graph`` prints."""
    lines = [f"frame graph of {info['scene']}"
             + (" after " + ", ".join(f"{k}={v}" for k, v in info["then"].items())
                if info["then"] else " (first frame)")]
    lines.append("")
    lines.append(f"{'pass':<16} {'status':<7} {'reads':<34} {'writes':<26} why")
    for p in info["passes"]:
        lines.append(f"{p['name']:<16} {p['status']:<7} {', '.join(p['reads']) or '-':<34} "
                     f"{', '.join(p['writes']) or '-':<26} {p['why']}")
    lines.append("")
    lines.append(f"{'resource':<16} {'lifetime':<10} {'bytes':>12}  {'first':<16} "
                 f"{'last':<16} descriptor")
    total = 0
    for r in info["resources"]:
        total += r["bytes"]
        lines.append(f"{r['name']:<16} {r['lifetime']:<10} {r['bytes']:>12,}  "
                     f"{r['first'] or '-':<16} {r['last'] or '-':<16} {r['desc']}")
    lines.append(f"{'':<16} {'':<10} {total:>12,}  ({mib(total)} declared by this frame)")
    lines.append("")
    lines.append(f"{'cache':<16} {'items':>6} {'bytes':>14} {'budget':>14} {'evictions':>10}")
    for name, s in info["memory"].items():
        budget = (mib(s["max_bytes"]) if s["max_bytes"] is not None
                  else f"{s['max_items']} items" if s["max_items"] is not None else "unbounded")
        lines.append(f"{name:<16} {s['items']:>6} {mib(s['bytes']):>14} {budget:>14} "
                     f"{s['evictions']:>10}")
    return "\n".join(lines)
