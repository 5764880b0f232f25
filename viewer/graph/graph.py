"""The frame graph: passes declare what they read and write, the graph decides what to draw.

Modelled on Filament's FrameGraph (``filament/src/fg``), kept small:

* A **pass** (:meth:`FrameGraph.add_pass`) names the resources it reads and writes, the scene and
  settings values its output depends on (``inputs``: any hashable values, compared by equality),
  and an ``execute(frame)`` that draws it. A pass may write a resource another pass wrote before
  it (in place: blending transparent surfaces into the lit radiance).
* A **resource** (:meth:`FrameGraph.create`) is a descriptor (:mod:`viewer.graph.resources`: size,
  format, channels) and a lifetime: *transient* (a pooled target taken at its first writer and
  given back after its last reader) or *kept* (it survives the frame: its content can be reused
  next frame, or read by the caller after it). :meth:`FrameGraph.import_resource` brings in
  something the graph does not allocate (an image stack's uploaded textures).
* :meth:`FrameGraph.compile` **culls** passes whose outputs nothing reads (a kept resource or a
  pass marked ``side_effect`` is always read), computes each transient's first and last use, and
  gives every resource version a **signature**: the writing pass's name and inputs and the
  signatures of what it read. A pass whose kept outputs were last drawn from the same signature is
  **reused** (not drawn); no reuse condition is written anywhere else. A pass whose output is
  ``volatile`` (Monte-Carlo accumulation) gets a signature no other frame shares, so nothing
  downstream of it is ever reused by mistake.
* :meth:`FrameGraph.execute` runs the passes in order, allocating transients from the
  :class:`~viewer.graph.pool.TargetPool` just before their first writer and returning them after
  their last reader.

``describe()`` and ``to_dot()`` report the compiled graph (``relight graph``): passes, resources
with their bytes and lifetimes, what was reused and why, what was culled.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Callable, Hashable

from .pool import TargetPool

_VOLATILE = itertools.count(1)  # signatures no other frame can share


@dataclass
class ResourceNode:
    name: str
    desc: object | None          # a descriptor of viewer.graph.resources, None when imported
    kept: bool = False           # survives the frame (reusable next frame / read by the caller)
    imported: object | None = None  # the object itself, for imported resources
    signature: Hashable = None   # the imported resource's content identity
    writers: list[str] = field(default_factory=list)
    readers: list[str] = field(default_factory=list)
    first: int | None = None     # index of the first pass (not culled) that uses it
    last: int | None = None      # index of the last
    handle: object | None = None  # the target while the graph runs

    @property
    def bytes(self) -> int:
        return 0 if self.desc is None else self.desc.bytes()


@dataclass
class PassNode:
    name: str
    reads: tuple[str, ...]
    writes: tuple[str, ...]
    inputs: dict
    execute: Callable
    side_effect: bool = False
    volatile: bool = False
    culled: bool = False
    reused: bool = False
    why: str = ""                # why it was drawn or reused (relight graph)
    signature: Hashable = None


class FrameResources:
    """What a pass's ``execute`` receives: the graph's resources by name (``frame[name]``: a
    target with ``.texture``/``.fbo``, a G-buffer, or an imported object) and
    :meth:`fbo` for several outputs at once."""

    def __init__(self, graph: "FrameGraph"):
        self._graph = graph
        self.samples = 1  # Monte-Carlo samples averaged in the radiance (the shade pass sets it)

    def __getitem__(self, name: str):
        node = self._graph.resources[name]
        if node.imported is not None:
            return node.imported
        if node.handle is None:
            raise KeyError(f"resource {name!r} is not allocated at this point of the frame")
        return node.handle

    def __contains__(self, name: str) -> bool:
        return name in self._graph.resources

    def fbo(self, *names: str):
        """A framebuffer with the colour targets ``names`` as attachments 0, 1, ... (multiple
        render targets; cached by the pool with its textures)."""
        return self._graph.pool.framebuffer(tuple(self[n].texture for n in names))

    def state(self, name: str) -> dict:
        """Per-resource state kept with a kept resource across frames (a running mean's count)."""
        return self._graph.pool.kept_state(self._graph.scope, name)


class FrameGraph:
    """One frame's passes and resources; see the module docstring."""

    def __init__(self, pool: TargetPool, scope: Hashable = "frame", reuse: bool = True):
        self.pool = pool
        self.scope = scope  # kept resources are stored per (scope, name)
        self.reuse = reuse
        self.resources: dict[str, ResourceNode] = {}
        self.passes: list[PassNode] = []
        self._compiled = False

    # ---- building ---------------------------------------------------------------------------
    def create(self, name: str, desc, kept: bool = False) -> str:
        """Declare a resource the graph allocates; returns its name."""
        if name in self.resources:
            raise ValueError(f"resource {name!r} declared twice")
        self.resources[name] = ResourceNode(name, desc, kept=kept)
        return name

    def import_resource(self, name: str, obj, signature: Hashable) -> str:
        """Declare a resource the graph does not allocate (``signature``: its content identity)."""
        if name in self.resources:
            raise ValueError(f"resource {name!r} declared twice")
        self.resources[name] = ResourceNode(name, None, imported=obj, signature=signature)
        return name

    def add_pass(self, name: str, execute: Callable, reads=(), writes=(), inputs=None,
                 side_effect: bool = False, volatile: bool = False) -> PassNode:
        """Declare a pass. ``execute(frame: FrameResources)`` draws it; ``inputs`` maps names to
        the scene/settings values its output depends on (beyond what it reads)."""
        for r in tuple(reads) + tuple(writes):
            if r not in self.resources:
                raise ValueError(f"pass {name!r} uses undeclared resource {r!r}")
        node = PassNode(name, tuple(reads), tuple(writes), dict(inputs or {}), execute,
                        side_effect=side_effect, volatile=volatile)
        for r in node.reads:
            self.resources[r].readers.append(name)
        for w in node.writes:
            self.resources[w].writers.append(name)
        self.passes.append(node)
        return node

    # ---- compiling --------------------------------------------------------------------------
    def compile(self) -> "FrameGraph":
        """Cull, compute lifetimes and signatures, decide reuse (see the module docstring)."""
        self._cull()
        live = [p for p in self.passes if not p.culled]
        for i, p in enumerate(live):
            for r in p.reads + p.writes:
                node = self.resources[r]
                node.first = i if node.first is None else node.first
                node.last = i
        self._signatures(live)
        self._compiled = True
        return self

    def _cull(self) -> None:
        """Mark passes none of whose outputs is needed: a pass is needed when it has a side
        effect, writes a kept resource, or writes something a needed later pass reads."""
        needed: set[str] = {name for name, r in self.resources.items() if r.kept}
        for p in reversed(self.passes):
            if p.side_effect or any(w in needed for w in p.writes):
                p.culled = False
                needed.update(p.reads)
            else:
                p.culled = True
                p.why = "culled: nothing reads " + ", ".join(p.writes) if p.writes else "culled"

    def _signatures(self, live: list[PassNode]) -> None:
        """Signatures of every resource version, then which passes must be drawn:

        1. a kept resource is *current* when what it was last drawn from equals the signature
           of its final version this frame (its last writer's);
        2. a pass is drawn when it is volatile, reuse is off, or it writes a transient or a
           resource that is not current;
        3. a pass writing (in place) a resource that a drawn pass also writes is drawn too, as
           the drawn one continues from its content (repeated until nothing changes);
        4. a drawn pass whose outputs are all transient and read only by reused passes is not
           needed this frame (skipped).
        """
        version: dict[str, Hashable] = {n: r.signature for n, r in self.resources.items()
                                        if r.imported is not None}
        for p in live:
            inputs = tuple(sorted(p.inputs.items()))
            p.signature = ((p.name, "volatile", next(_VOLATILE)) if p.volatile else
                           (p.name, inputs, tuple((r, version.get(r)) for r in p.reads)))
            for w in p.writes:
                version[w] = p.signature
        draw: dict[str, str] = {}  # pass -> why it is drawn
        stored = {n: self.pool.kept_signature(self.scope, n, r.desc)
                  for n, r in self.resources.items() if r.kept}
        for p in live:
            why = self._must_draw(p, version, stored)
            if why:
                draw[p.name] = why
        changed = True
        while changed:  # rule 3: in-place chains are drawn whole
            changed = False
            dirty = {w for p in live if p.name in draw for w in p.writes}
            for p in live:
                if p.name not in draw and dirty & set(p.writes):
                    draw[p.name] = "continues a resource drawn again this frame"
                    changed = True
        for p in reversed(live):  # rule 4
            if p.name in draw and all(not self.resources[w].kept for w in p.writes) and \
                    all(reader not in draw for w in p.writes
                        for reader in self.resources[w].readers) and not p.side_effect:
                del draw[p.name]
                p.why = "not needed: its readers are reused"
                p.reused = True
        for p in live:
            if p.name in draw:
                p.reused, p.why = False, draw[p.name]
            elif not p.why:
                p.reused, p.why = True, "inputs unchanged"

    def _must_draw(self, p: PassNode, version: dict, stored: dict) -> str:
        """Why ``p`` must be drawn (rule 2), or "" when its outputs may be reused."""
        if p.volatile:
            return "volatile output (accumulates)"
        if not self.reuse:
            return "reuse off (every pass drawn)"
        if not p.writes:
            return "no outputs to keep"
        for w in p.writes:
            if not self.resources[w].kept:
                return f"writes transient {w}"
            if stored[w] is None:
                return f"{w}: first frame at this size and format"
            if stored[w] != version[w]:
                return f"{w} changed: " + ", ".join(_changed(stored[w], version[w]))
        return ""

    # ---- running ----------------------------------------------------------------------------
    def execute(self, on_pass: Callable[[str | None], None] | None = None) -> FrameResources:
        """Run the compiled graph; returns the frame's resources (kept ones stay valid).
        ``on_pass(name)`` is called before each drawn pass and with None after the last (the
        renderer's profiler)."""
        if not self._compiled:
            self.compile()
        frame = FrameResources(self)
        live = [p for p in self.passes if not p.culled]
        for name, node in self.resources.items():  # kept resources: this frame's targets
            if node.kept and node.desc is not None:
                node.handle = self.pool.acquire_kept(self.scope, name, node.desc)
        for i, p in enumerate(live):
            for r in p.reads + p.writes:
                node = self.resources[r]
                if node.handle is None and node.imported is None and node.first == i:
                    node.handle = self.pool.acquire(node.desc)
            if not p.reused:
                if on_pass is not None:
                    on_pass(p.name)
                p.execute(frame)
                for w in p.writes:
                    if self.resources[w].kept:
                        self.pool.set_kept_signature(self.scope, w, p.signature)
            for r in set(p.reads + p.writes):
                node = self.resources[r]
                if not node.kept and node.imported is None and node.last == i:
                    self.pool.release(node.desc, node.handle)  # back to the pool
        if on_pass is not None:
            on_pass(None)
        self.pool.end_frame(self.scope, {n for n, r in self.resources.items() if r.kept})
        return frame

    # ---- reporting --------------------------------------------------------------------------
    def describe(self) -> dict:
        """The compiled graph as plain data (``relight graph``)."""
        return {
            "passes": [{"name": p.name, "reads": list(p.reads), "writes": list(p.writes),
                        "status": "culled" if p.culled else ("reused" if p.reused else "drawn"),
                        "why": p.why} for p in self.passes],
            "resources": [{"name": r.name,
                           "desc": "imported" if r.desc is None else r.desc.describe(),
                           "bytes": r.bytes,
                           "lifetime": ("imported" if r.imported is not None
                                        else "kept" if r.kept else "transient"),
                           "first": _pass_name(self, r.first), "last": _pass_name(self, r.last)}
                          for r in self.resources.values()],
        }

    def to_dot(self) -> str:
        """Graphviz DOT of the compiled graph: passes as boxes (drawn, reused or culled),
        resources as ellipses (kept ones doubled), edges for reads and writes."""
        lines = ["digraph frame {", "  rankdir=LR;", '  node [fontname="Helvetica"];']
        colours = {"drawn": "#cfe8ff", "reused": "#d8f5d0", "culled": "#eeeeee"}
        for p in self.passes:
            status = "culled" if p.culled else ("reused" if p.reused else "drawn")
            lines.append(f'  "pass:{p.name}" [shape=box, style="rounded,filled", '
                         f'fillcolor="{colours[status]}", label="{p.name}\\n{status}"];')
        for r in self.resources.values():
            shape = "doubleoctagon" if r.kept else "ellipse"
            label = r.name if r.desc is None else f"{r.name}\\n{r.desc.describe()}"
            lines.append(f'  "res:{r.name}" [shape={shape}, label="{label}"];')
        for p in self.passes:
            for r in p.reads:
                lines.append(f'  "res:{r}" -> "pass:{p.name}";')
            for w in p.writes:
                lines.append(f'  "pass:{p.name}" -> "res:{w}";')
        lines.append("}")
        return "\n".join(lines) + "\n"


def _pass_name(graph: FrameGraph, index: int | None) -> str | None:
    if index is None:
        return None
    live = [p for p in graph.passes if not p.culled]
    return live[index].name


def _changed(old, new) -> list[str]:
    """Names of the declared inputs (or read resources) that differ between two signatures."""
    try:
        _, old_inputs, old_reads = old
        _, new_inputs, new_reads = new
        a, b = dict(old_inputs), dict(new_inputs)
        ra, rb = dict(old_reads), dict(new_reads)
    except (TypeError, ValueError):
        return ["an upstream volatile pass" if "volatile" in (old[1], new[1]) else "signature"]
    out = [k for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    out += [f"{k} (read)" for k in sorted(set(ra) | set(rb)) if ra.get(k) != rb.get(k)]
    return out or ["signature"]
