"""The one module that creates OpenGL contexts.

Headless rendering uses a standalone EGL context: the GPU driver where one is installed, Mesa's
llvmpipe software rasteriser otherwise (surfaceless EGL is the maintained successor of OSMesa).
``software=True`` forces llvmpipe. A window context (glfw) will be created here too, *before* any
standalone context, and passed around explicitly: moderngl makes a standalone context the global one
silently, so every function in this project takes ``ctx`` as an argument.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import GLContextError

REQUIRED_GL = 430  # compute shaders and std430 buffers (precomputation, parity kernels)

_MESA_EGL_VENDOR = "/usr/share/glvnd/egl_vendor.d/50_mesa.json"


@dataclass(frozen=True)
class ContextOptions:
    software: bool = False  # force Mesa llvmpipe even where a GPU driver exists
    device_index: int = 0  # EGL device when several GPUs are present


def _force_software_env() -> None:
    # Must happen before libEGL is loaded in this process; later calls cannot switch vendors.
    os.environ["LIBGL_ALWAYS_SOFTWARE"] = "1"
    os.environ.setdefault("GALLIUM_DRIVER", "llvmpipe")
    if os.path.exists(_MESA_EGL_VENDOR):
        os.environ.setdefault("__EGL_VENDOR_LIBRARY_FILENAMES", _MESA_EGL_VENDOR)


def create_context(options: ContextOptions = ContextOptions()):
    """Create a standalone headless OpenGL 4.3+ core context through EGL.

    Raises :class:`GLContextError` with one line when EGL or a recent enough driver is missing.
    """
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - dependency missing
        raise GLContextError(f"moderngl is not installed ({exc})") from None
    if options.software or os.environ.get("RELIGHT_SOFTWARE_GL") == "1":
        _force_software_env()
    try:
        ctx = moderngl.create_context(standalone=True, backend="egl", require=REQUIRED_GL,
                                      device_index=options.device_index)
    except Exception as exc:  # glcontext raises bare Exceptions with multi-line text
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise GLContextError(
            f"cannot create a headless EGL OpenGL {REQUIRED_GL // 100}.{REQUIRED_GL % 100 // 10} "
            f"context ({first}); install Mesa's EGL (Debian: libegl1 libegl-mesa0 libgl1-mesa-dri) "
            f"or a GPU driver") from None
    return ctx


def _float_target_bits(ctx, dtype: str) -> int:
    """Mantissa bits a colour target of ``dtype`` keeps, measured by clearing to 1 + 2^-k."""
    fbo = ctx.simple_framebuffer((1, 1), components=4, dtype=dtype)
    bits = 0
    try:
        for k in range(1, 40):
            value = 1.0 + 2.0 ** -k
            fbo.use()
            fbo.clear(value, value, value, value)
            got = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)[0]
            if float(got) != value:
                break
            bits = k
    finally:
        fbo.release()
    return bits


def gl_info(ctx) -> dict:
    """Renderer, version, extensions and the measured precision of float render targets."""
    info = ctx.info
    return {
        "renderer": info.get("GL_RENDERER"),
        "vendor": info.get("GL_VENDOR"),
        "version": info.get("GL_VERSION"),
        "glsl": info.get("GL_SHADING_LANGUAGE_VERSION"),
        "version_code": ctx.version_code,
        "software": "llvmpipe" in str(info.get("GL_RENDERER", "")).lower(),
        "max_texture_size": info.get("GL_MAX_TEXTURE_SIZE"),
        "max_color_attachments": info.get("GL_MAX_COLOR_ATTACHMENTS"),
        "float_target_mantissa_bits": {"f2": _float_target_bits(ctx, "f2"),
                                       "f4": _float_target_bits(ctx, "f4")},
        "extensions": sorted(ctx.extensions),
    }
