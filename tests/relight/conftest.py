"""Fixtures of the viewer-window tests (test_app_*.py): one offscreen :class:`Viewer` per module
(``viewer``) and, per test, that viewer reset to the test scene (``fresh``)."""
import pytest


@pytest.fixture(scope="module")
def viewer():
    from relight.app.window import Viewer
    from viewer.errors import GLContextError
    from viewer_helpers import SIZE, sphere_scene

    try:
        v = Viewer(sphere_scene(), window_size=SIZE, offscreen=True)
    except GLContextError as exc:  # pragma: no cover - only where glfw has no Null/EGL platform
        pytest.skip(f"no offscreen window: {exc}")
    yield v
    v.close()


@pytest.fixture
def fresh(viewer):
    """The module's viewer, reset to the test scene with the UI hidden."""
    from relight.app.state import state_from_scene
    from viewer_helpers import sphere_scene

    viewer.state = state_from_scene(sphere_scene())
    viewer.state.show_ui = viewer.state.show_overlay = False
    viewer.run(frames=1)
    return viewer
