"""OpenGL plumbing: contexts (:mod:`.context`), shader assembly and program cache (:mod:`.programs`),
and the compute harness that evaluates single GLSL library functions (:mod:`.kernels`)."""
from .context import ContextOptions, create_context, gl_info, make_current
from .programs import Programs, assemble

__all__ = ["ContextOptions", "create_context", "gl_info", "make_current", "Programs", "assemble"]
