"""The offscreen viewer tests' scene and readers: a grey sphere (:func:`sphere_scene`), what the
window shows (:func:`shown`, :func:`to_linear`) and the headless render to compare it with
(:func:`headless`), and input through the glfw backend's callbacks (:func:`click`,
:func:`drag_to`, :func:`release`, :func:`drop_files`). The viewer itself is the ``viewer`` /
``fresh`` fixtures of tests/relight/conftest.py."""
import numpy as np

from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

SIZE = (96, 96)


def sphere_scene():
    return scene_from_dict({
        "camera": {"position": [0, 0, 3.2], "fov_y": 40, "size": list(SIZE)},
        "environment": {"procedural": "studio", "width": 128},
        "objects": [{"type": "sphere", "material": {"albedo": [0.6, 0.6, 0.6], "roughness": 0.0,
                                                   "specular": 1.0}}],
        "render": {"tonemap": "none", "exposure": -1.0}})


def shown(viewer, frames=1) -> np.ndarray:
    viewer.run(frames=frames)
    return viewer.read_framebuffer()


def to_linear(rgba8: np.ndarray) -> np.ndarray:
    c = rgba8[..., :3].astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def scene_image(viewer) -> np.ndarray:
    """The shown frame with the panel hidden for it, linear RGB; the panel is back after."""
    viewer.state.show_ui = False
    rgb = to_linear(shown(viewer))[..., :3]
    viewer.state.show_ui = True
    viewer.run(frames=2)
    return rgb


def headless(ctx, scene, **kw):
    r = Renderer(ctx=ctx)
    try:
        return r.render(scene, **kw)
    finally:
        r.release()


def drop_files(viewer, paths) -> None:
    """Drop ``paths`` on the window as the window system does: through the C drop callback the
    viewer registered with glfw (what ``glfwSetDropCallback`` holds), then one frame."""
    import ctypes

    import glfw

    window = viewer.window.window
    address = ctypes.cast(ctypes.pointer(window), ctypes.POINTER(ctypes.c_long)).contents.value
    _, c_callback = glfw._window_drop_callback_repository[address]
    names = (ctypes.c_char_p * len(paths))(*[str(p).encode() for p in paths])
    c_callback(window, len(paths), names)
    viewer.run(frames=1)


def click(viewer, x, y, frames_down=2):
    """Press and release the left button at window pixel (x, y) through the glfw backend."""
    from imgui_bundle import imgui

    b, addr = imgui.backends, viewer.window.address
    b.glfw_cursor_enter_callback(addr, 1)
    b.glfw_cursor_pos_callback(addr, float(x), float(y))
    viewer.run(frames=1)
    b.glfw_mouse_button_callback(addr, 0, 1, 0)  # GLFW_PRESS
    viewer.run(frames=frames_down)


def drag_to(viewer, x, y, frames=2):
    from imgui_bundle import imgui

    imgui.backends.glfw_cursor_pos_callback(viewer.window.address, float(x), float(y))
    viewer.run(frames=frames)


def release(viewer):
    from imgui_bundle import imgui

    imgui.backends.glfw_mouse_button_callback(viewer.window.address, 0, 0, 0)  # GLFW_RELEASE
    viewer.run(frames=2)
