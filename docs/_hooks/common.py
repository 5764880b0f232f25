"""Helpers shared by the docs' page generators (docs/_hooks/generate.py, scene_page.py)."""
from __future__ import annotations


def _esc(text: str) -> str:
    """Plain text (with `code` spans kept) for a Markdown table cell."""
    parts = " ".join(str(text).split()).split("`")
    for i in range(0, len(parts), 2):  # outside code spans
        for a, b in (("&", "&amp;"), ("<", "&lt;"), (">", "&gt;"), ("*", "\\*"),
                     ("_", "\\_"), ("[", "\\["), ("]", "\\]")):
            parts[i] = parts[i].replace(a, b)
    if len(parts) % 2 == 0:  # an unmatched backtick: keep it literal
        parts[-2] += "\\`" + parts.pop()
    return "`".join(parts).replace("|", "\\|")


def _code(value) -> str:
    s = str(value).replace("|", "\\|")
    return f"`{s}`" if s else ""
