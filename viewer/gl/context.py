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
from .programs import assemble

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


def make_current(ctx) -> None:
    """Make ``ctx`` the current context of this thread and leave it current.

    Several contexts can live in one process (a window and a headless one, or tests that run the
    CLI in-process); every entry point that issues GL calls makes its own context current first.
    (moderngl's ``with ctx:`` would restore the previously current context on exit, which for a
    freshly created standalone context is *no* context, breaking later calls.)
    """
    ctx.__enter__()


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




def texture_filter_bits(ctx, probes: int = 1 << 16) -> dict[str, int]:
    """Fraction bits the texture unit keeps for bilinear weights (``subtexel``) and for the lod
    fraction between mip levels (``mipmap``), measured: a 4x2 R32F texture holding 0 | 1 in
    level 0 and 1 in level 1 is read at ``probes`` evenly spaced positions between two texel
    centres (and lods between two levels); k distinct results mean log2(k) bits. GPUs keep 8
    (Vulkan's subTexelPrecisionBits / mipmapPrecisionBits; 4 allowed), llvmpipe filters in
    float32 and shows the probe's resolution (16). Used by the parity checks' error envelopes."""
    prog = ctx.compute_shader(assemble("passes/texture_filter_probe.comp").source)
    level0 = np.array([[0, 0, 1, 1], [0, 0, 1, 1]], np.float32)
    tex = ctx.texture((4, 2), 1, level0.tobytes(), dtype="f4")
    tex.build_mipmaps(0, 1)
    tex.write(np.ones((1, 2), np.float32).tobytes(), level=1)
    tex.filter = (ctx.LINEAR_MIPMAP_LINEAR, ctx.LINEAR)
    tex.repeat_x = tex.repeat_y = False
    out = ctx.buffer(reserve=4 * probes)
    bits = {}
    try:
        tex.use(0)
        prog["u_tex"].value = 0
        prog["u_count"].value = probes
        out.bind_to_storage_buffer(0)
        for mip, name in ((0, "subtexel"), (1, "mipmap")):
            prog["u_mip"].value = mip
            prog.run(group_x=(probes + 255) // 256)
            ctx.memory_barrier()
            values = np.frombuffer(out.read(), dtype=np.float32)
            bits[name] = int(np.floor(np.log2(max(len(np.unique(values)), 1))))
    finally:
        out.release()
        tex.release()
        prog.release()
    return bits


_GL_SHADING_LANGUAGE_VERSION = 0x8B8C


def glsl_version(ctx) -> str | None:
    """The driver's ``GL_SHADING_LANGUAGE_VERSION`` string (``"4.50"``), or None where it cannot
    be read. moderngl's ``ctx.info`` does not query it, so this asks ``glGetString`` itself,
    through EGL's entry points (headless and window contexts are both EGL here), with ``ctx``
    made current."""
    import ctypes

    egl = _egl_lib()
    if egl is None:
        return None
    make_current(ctx)
    egl.eglGetProcAddress.restype = ctypes.c_void_p
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    address = egl.eglGetProcAddress(b"glGetString")
    if not address:
        return None
    value = ctypes.CFUNCTYPE(ctypes.c_char_p, ctypes.c_uint)(address)(
        _GL_SHADING_LANGUAGE_VERSION)
    return value.decode("ascii", "replace").strip() if value else None


def is_software(ctx) -> bool:
    """Whether ``ctx`` is Mesa's llvmpipe software rasteriser."""
    return "llvmpipe" in str(ctx.info.get("GL_RENDERER", "")).lower()


def gl_info(ctx) -> dict:
    """Renderer, version, extensions and the measured precision of float render targets."""
    info = ctx.info
    return {
        "renderer": info.get("GL_RENDERER"),
        "vendor": info.get("GL_VENDOR"),
        "version": info.get("GL_VERSION"),
        "glsl": glsl_version(ctx),
        "version_code": ctx.version_code,
        "software": is_software(ctx),
        "max_texture_size": info.get("GL_MAX_TEXTURE_SIZE"),
        "max_color_attachments": info.get("GL_MAX_COLOR_ATTACHMENTS"),
        "float_target_mantissa_bits": {"f2": _float_target_bits(ctx, "f2"),
                                       "f4": _float_target_bits(ctx, "f4")},
        "texture_filter_bits": texture_filter_bits(ctx),
        "extensions": sorted(ctx.extensions),
    }


# ---- windows --------------------------------------------------------------------------------
# A window's context is created by glfw, then wrapped by moderngl (``ctx.screen`` is the window's
# default framebuffer). ``offscreen=True`` uses glfw's Null platform with an EGL context: a real
# default framebuffer and real input plumbing, no display needed (what CI uses). imgui-bundle ships
# its own libglfw; it is imported before ``glfw`` so that both drive the same library.

_EGL_DRAW, _EGL_READ = 0x3059, 0x305A
_glfw_state = {"platform": None, "windows": 0}


@dataclass
class WindowContext:
    """A glfw window and the moderngl context made from it (create with :func:`create_window`)."""

    window: object  # glfw window handle
    ctx: object  # moderngl.Context of the window; ctx.screen is its default framebuffer
    offscreen: bool
    _previous: tuple | None = None  # the EGL context current before the window's (restored)
    _closed: bool = False

    @property
    def address(self) -> int:
        """The window pointer as an integer (imgui-bundle's native backends take it)."""
        import ctypes

        return ctypes.cast(self.window, ctypes.c_void_p).value

    def framebuffer_size(self) -> tuple[int, int]:
        import glfw

        return tuple(glfw.get_framebuffer_size(self.window))

    def make_current(self) -> None:
        import glfw

        glfw.make_context_current(self.window)

    def close(self) -> None:
        """Destroy the window and make the previously current (standalone EGL) context current."""
        if self._closed:
            return
        import glfw

        self._closed = True
        self.ctx.release()
        glfw.destroy_window(self.window)
        _glfw_state["windows"] -= 1
        if self._previous is not None:
            _egl_make_current(self._previous)


class _GlfwLoader:
    """moderngl's context loader for a glfw window: entry points through glfwGetProcAddress, and
    ``ctx.__enter__`` (:func:`make_current`) makes the window's context current."""

    def __init__(self, glfw, window):
        self._glfw = glfw
        self._window = window

    def load_opengl_function(self, name: str) -> int:
        return self._glfw.get_proc_address(name) or 0

    def __enter__(self):
        self._glfw.make_context_current(self._window)

    def __exit__(self, *args):
        pass

    def release(self):
        pass


def _egl_lib():
    import ctypes

    try:
        egl = ctypes.CDLL("libEGL.so.1")
    except OSError:
        return None
    for name in ("eglGetCurrentContext", "eglGetCurrentDisplay", "eglGetCurrentSurface"):
        getattr(egl, name).restype = ctypes.c_void_p
    egl.eglGetCurrentSurface.argtypes = [ctypes.c_int]
    egl.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
    return egl


def _egl_current() -> tuple | None:
    """The calling thread's current EGL (display, draw, read, context), or None."""
    egl = _egl_lib()
    if egl is None or not egl.eglGetCurrentContext():
        return None
    return (egl.eglGetCurrentDisplay(), egl.eglGetCurrentSurface(_EGL_DRAW),
            egl.eglGetCurrentSurface(_EGL_READ), egl.eglGetCurrentContext())


def _egl_make_current(saved: tuple) -> None:
    egl = _egl_lib()
    if egl is not None:
        egl.eglMakeCurrent(*saved)


def _import_glfw():
    import sys

    if "glfw" in sys.modules and "imgui_bundle" not in sys.modules:
        raise GLContextError("glfw was imported before imgui_bundle; import imgui_bundle first so "
                             "both use the same libglfw")
    try:
        import imgui_bundle  # noqa: F401  (sets PYGLFW_LIBRARY to its own libglfw)
    except ImportError:
        pass  # a window without Dear ImGui still works with pip's glfw
    try:
        import glfw
    except ImportError as exc:  # pragma: no cover - dependency missing
        raise GLContextError(f"glfw is not installed ({exc})") from None
    return glfw


def create_window(size: tuple[int, int] = (1280, 800), title: str = "relight",
                  offscreen: bool = False, options: ContextOptions = ContextOptions()
                  ) -> WindowContext:
    """Open a glfw window with an OpenGL 4.3+ core context and wrap it in moderngl.

    ``offscreen=True``: glfw's Null platform with an EGL context (no display needed; the window
    is invisible but has a real default framebuffer). Create windows before any standalone
    context when you can; if one is current, :meth:`WindowContext.close` makes it current again.
    Raises :class:`GLContextError` with one line when no window can be made.
    """
    glfw = _import_glfw()
    if options.software or os.environ.get("RELIGHT_SOFTWARE_GL") == "1":
        _force_software_env()
    previous = _egl_current()
    platform = glfw.PLATFORM_NULL if offscreen else glfw.ANY_PLATFORM
    if _glfw_state["platform"] != platform:
        if _glfw_state["windows"]:
            raise GLContextError("cannot mix offscreen and on-screen windows in one process")
        if _glfw_state["platform"] is not None:
            glfw.terminate()
        glfw.init_hint(glfw.PLATFORM, platform)
        errors: list[str] = []
        glfw.set_error_callback(lambda code, text: errors.append(
            text.decode() if isinstance(text, bytes) else str(text)))
        if not glfw.init():
            _glfw_state["platform"] = None
            why = errors[-1] if errors else "glfw.init failed"
            hint = "" if offscreen else "; no display? use --offscreen"
            raise GLContextError(f"cannot initialise glfw ({why}){hint}")
        _glfw_state["platform"] = platform
    glfw.default_window_hints()
    # EGL on every platform: moderngl's "egl" backend then knows how to make it current again
    glfw.window_hint(glfw.CONTEXT_CREATION_API, glfw.EGL_CONTEXT_API)
    if offscreen:
        glfw.window_hint(glfw.VISIBLE, glfw.FALSE)
    glfw.window_hint(glfw.CLIENT_API, glfw.OPENGL_API)
    glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, REQUIRED_GL // 100)
    glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, REQUIRED_GL % 100 // 10)
    glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
    glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, glfw.TRUE)
    window = glfw.create_window(int(size[0]), int(size[1]), title, None, None)
    if not window:
        if previous is not None:
            _egl_make_current(previous)
        raise GLContextError(f"cannot open a {size[0]}x{size[1]} OpenGL "
                             f"{REQUIRED_GL // 100}.{REQUIRED_GL % 100 // 10} window"
                             + (" (glfw Null platform, EGL)" if offscreen else ""))
    _glfw_state["windows"] += 1
    glfw.make_context_current(window)
    glfw.swap_interval(0 if offscreen else 1)
    import moderngl

    try:
        moderngl.init_context(loader=_GlfwLoader(glfw, window))  # becomes moderngl's default
        ctx = moderngl.get_context()
        if ctx.version_code < REQUIRED_GL:
            raise ValueError(f"OpenGL {ctx.version_code} < {REQUIRED_GL}")
    except Exception as exc:
        glfw.destroy_window(window)
        _glfw_state["windows"] -= 1
        if previous is not None:
            _egl_make_current(previous)
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise GLContextError(f"cannot use the window's OpenGL context ({first})") from None
    return WindowContext(window=window, ctx=ctx, offscreen=offscreen, _previous=previous)
