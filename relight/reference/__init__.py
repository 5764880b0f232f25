"""``relight reference``: path-traced ground truth with Mitsuba 3 and our own BSDF.

:func:`render_reference` renders a :class:`~viewer.scene.description.Scene` (spheres, planes, the material
grid, glTF/OBJ meshes; the environment and every punctual light, :mod:`relight.reference.lights`)
with the rasteriser's per-pixel rays and returns the mean radiance with its per-pixel standard
error; :func:`write_reference` / :func:`read_reference` store it beside its metadata. :mod:`relight.reference.compare` scores a
render against it (per-pixel z-test, bias, median relative error)."""
from .render import (
                     AOVS,
                     Reference,
                     ReferenceOptions,
                     camera_rays,
                     load_mitsuba,
                     read_reference,
                     render_reference,
                     write_reference,
)
from .scene import ReferenceError, check_traceable

__all__ = ["AOVS", "Reference", "ReferenceError", "ReferenceOptions", "camera_rays",
           "check_traceable", "load_mitsuba", "read_reference", "render_reference",
           "write_reference"]
