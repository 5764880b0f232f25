"""User-facing errors.

Every problem a user can cause (a bad file, an unknown key, a missing GL driver) is raised as a
:class:`RelightError` whose message is one line naming the thing and the problem. The CLI prints it
as ``relight: error: <message>`` and exits with status 2; library callers catch it like any error.
"""
from __future__ import annotations

import os


class RelightError(Exception):
    """A one-line, user-facing error. ``where`` is the file (or key) the problem is in."""

    exit_code = 2

    def __init__(self, problem: str, where: str | os.PathLike | None = None):
        self.problem = " ".join(str(problem).split())  # keep it to one line
        self.where = None if where is None else str(where)
        super().__init__(self.problem if self.where is None else f"{self.where}: {self.problem}")


class InputError(RelightError):
    """Bad input data: a corrupt or unreadable file, wrong channel counts, NaN where none may be."""


class SceneError(RelightError):
    """A scene description that cannot be used: unknown keys, bad values, unknown model names."""


class GLContextError(RelightError):
    """No usable OpenGL context (no EGL, version too old, window system unavailable)."""


class ShaderCompileError(RelightError):
    """A GLSL compile or link error, with file names and lines mapped back to ``shaders/``."""


class AssetNote(UserWarning):
    """A warning that says what was assumed about an input rather than read from it (an asset's
    up axis: :mod:`viewer.scene.assets`); the CLI prints it as ``relight: note: <message>``."""
