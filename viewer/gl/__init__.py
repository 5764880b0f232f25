"""OpenGL plumbing: contexts (:mod:`.context`), shader assembly and program cache (:mod:`.programs`),
and the compute harness that evaluates single GLSL library functions (:mod:`.kernels`).

Imports: :mod:`viewer.errors`, :mod:`viewer.cache`; nothing of scenes, passes or the graph.
"""
from .context import ContextOptions, create_context, gl_info, make_current
from .programs import Programs, assemble

__all__ = ["ContextOptions", "create_context", "gl_info", "make_current", "Programs", "assemble"]
