"""Screen-space contact shadows on an image-space stack (no shadow map can hold its surfaces):
a box on a floor, its depth and normals written here by ray casting, lit by a directional
light. The floor beside the box on the side away from the light is dark where the analytic
shadow falls within the march's length, lit where the march passes farther from the box than the
thickness the buffer's surfaces are assumed to have (half the march: a march passing just behind
the box is taken for a hit, screen space cannot tell), and a lit plane never shadows itself, down
to grazing light."""
import dataclasses

import numpy as np
import pytest
from scipy import ndimage

from viewer.geometry.imagespace import ImageGBuffer, view_dirs_cs
from viewer.renderer import Renderer
from viewer.scene.description import ObjectSpec, scene_from_dict

W, H, FOV = 128, 96, 50.0
LENGTH = 0.8  # contact_length: world units the march covers
# the floor, seen from the stack's camera (origin, looking down -Z): through ORIGIN, tilted
# towards the camera; its frame's axes (x along the camera's right)
ORIGIN = np.array([0.0, -1.0, -3.5])
E_Y = np.array([0.0, 1.0, 0.7]) / np.linalg.norm([0.0, 1.0, 0.7])
E_X = np.array([1.0, 0.0, 0.0])
E_Z = np.cross(E_X, E_Y)
BOX = (np.array([-0.3, 0.0, -0.3]), np.array([0.3, 0.6, 0.3]))  # floor frame, on the floor


def to_floor(v):
    return np.stack([v @ E_X, v @ E_Y, v @ E_Z], axis=-1)


def from_floor(v):
    return v[..., :1] * E_X + v[..., 1:2] * E_Y + v[..., 2:3] * E_Z


def slab(o, d, lo, hi):
    """Entry distance of rays o + t d into the box [lo, hi] (floor frame), inf where missed."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - o) / d, (hi - o) / d
    tmin = np.nanmax(np.minimum(t0, t1), axis=-1)
    tmax = np.nanmin(np.maximum(t0, t1), axis=-1)
    hit = (tmax >= np.maximum(tmin, 0.0))
    return np.where(hit, np.maximum(tmin, 0.0), np.inf), np.minimum(t0, t1).argmax(-1), \
        np.sign(d)


def box_distance(points):
    """Distance of floor-frame points [..., 3] from the box."""
    lo, hi = BOX
    return np.linalg.norm(np.maximum(np.maximum(lo - points, points - hi), 0.0), axis=-1)


def stack(with_box=True):
    """The stack's channels and the floor pixels' floor-frame points (NaN elsewhere)."""
    d = view_dirs_cs(W, H, FOV).astype(np.float64)  # [H, W, 3], row 0 at the top
    o = to_floor(-ORIGIN)  # the camera in the floor frame
    df = to_floor(d)
    t_floor = np.where(df[..., 1] < 0, -o[1] / df[..., 1], np.inf)
    t_box, axis, sgn = slab(o, df, *BOX) if with_box else (np.full(d.shape[:2], np.inf),) * 3
    t = np.minimum(t_floor, t_box)
    hit = np.isfinite(t)
    p = o + df * np.where(hit, t, 0.0)[..., None]
    normal_f = np.zeros_like(p)
    normal_f[..., 1] = 1.0
    if with_box:
        on_box = t_box < t_floor
        box_n = np.zeros_like(p)
        np.put_along_axis(box_n, axis[..., None], -np.take_along_axis(sgn, axis[..., None], -1),
                          -1)
        normal_f = np.where(on_box[..., None], box_n, normal_f)
    else:
        on_box = np.zeros(hit.shape, bool)
    depth = np.where(hit, t * -d[..., 2], 0.0)
    ch = {"albedo": np.full((H, W, 3), 0.5, np.float32),
          "normal": from_floor(normal_f).astype(np.float32),
          "roughness": np.full((H, W, 1), 0.9, np.float32),
          "metallic": np.zeros((H, W, 1), np.float32),
          "specular": np.zeros((H, W, 1), np.float32),
          "ao": np.ones((H, W, 1), np.float32),
          "depth": depth[..., None].astype(np.float32),
          "alpha": hit[..., None].astype(np.float32)}
    floor = np.where((hit & ~on_box)[..., None], p, np.nan)
    return ImageGBuffer(channels=ch, fov_y=FOV), floor


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def visibility(renderer, image, light_f, name):
    """Radiance with contact shadows / without, the light towards light_f (floor frame)."""
    obj = ObjectSpec(type="gbuffer", path=f"in-memory-contact-{name}")
    renderer.add_geometry(obj, image)
    light = from_floor(np.asarray(light_f, float) / np.linalg.norm(light_f))
    sc = scene_from_dict({
        "environment": {"procedural": "white", "width": 32, "intensity": 0.0},
        "lights": [{"type": "directional", "direction": light.tolist(), "intensity": 3.0}],
        "objects": [], "render": {"tonemap": "none", "contact_length": LENGTH}})
    sc = dataclasses.replace(sc, objects=(obj,))
    lit = renderer.render(sc).radiance[..., 0]
    free = renderer.render(sc.with_render(contact_shadows="off")).radiance[..., 0]
    return lit / np.maximum(free, 1e-9), free


def test_a_box_on_a_floor_casts_its_contact_shadow(renderer):
    light_f = np.array([0.8, 0.6, 0.2])  # 37 degrees above the floor, from +x
    image, floor = stack()
    vis, free = visibility(renderer, image, light_f, "box")
    on_floor = np.isfinite(floor[..., 0]) & (free > 1e-6)
    # analytic: the segment of the march's length from the floor point towards the light meets
    # the box
    lf = light_f / np.linalg.norm(light_f)
    t, _, _ = slab(np.nan_to_num(floor), np.broadcast_to(lf, floor.shape), *BOX)
    truth = on_floor & (t < LENGTH)
    core = ndimage.binary_erosion(truth, iterations=2)
    assert core.sum() > 100  # a real shadow beside the box
    assert (vis[core] < 0.5).mean() > 0.97, (vis[core] < 0.5).mean()
    # the march's closest approach to the box (a longer march: its samples are jittered)
    steps = np.linspace(0.0, 1.2 * LENGTH, 25)
    gap = np.min([box_distance(np.nan_to_num(floor) + s * lf) for s in steps], axis=0)
    far = on_floor & ~ndimage.binary_dilation(gap < 0.5 * LENGTH + 0.1, iterations=2)
    assert far.sum() > 3000
    assert (vis[far] > 0.999).all(), np.argwhere(far & (vis <= 0.999))[:10]


@pytest.mark.parametrize("elevation", [60.0, 20.0, 5.0])
def test_no_contact_shadow_on_a_lit_plane(renderer, elevation):
    e = np.radians(elevation)
    image, floor = stack(with_box=False)
    vis, free = visibility(renderer, image, [np.cos(e), np.sin(e), 0.3 * np.cos(e)],
                           f"plane{elevation}")
    lit = np.isfinite(floor[..., 0]) & (free > 1e-6)
    assert lit.sum() > 3000
    assert vis[lit].min() > 0.999, (elevation, np.argwhere(lit & (vis <= 0.999))[:10])
