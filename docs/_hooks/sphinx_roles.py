"""Griffe extension (mkdocs.yml: mkdocstrings' ``extensions``): the docstrings are written with
Sphinx cross-reference roles (``:class:`~viewer.scene.description.Scene```), which Markdown would print
verbatim; turn each into inline code of its target (the last component for ``~`` targets)."""
from __future__ import annotations

import re

import griffe

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|exc|obj|const|ref|term):`([^`]+)`")


def _code(match: re.Match) -> str:
    target = match.group(1).strip()
    if target.startswith("~"):
        target = target[1:].rsplit(".", 1)[-1]
    return f"`{target.lstrip('.')}`"


class SphinxRoles(griffe.Extension):
    def _fix(self, obj) -> None:
        doc = getattr(obj, "docstring", None)
        if doc is not None and ":`" in doc.value:
            doc.value = _ROLE.sub(_code, doc.value)

    def on_object(self, *, obj, **kwargs) -> None:  # griffe >= 1.x, after loading
        self._fix(obj)

    def on_instance(self, *, obj, **kwargs) -> None:  # older griffe
        self._fix(obj)
