"""Asset files the asset tests write (test_assets.py, test_assets_cli.py): an off-centre box glTF,
and a splat capture - a grey ground of discs with a ball on it, red above its equator and blue
below, plus far outliers - written in any up-axis convention."""
import numpy as np
from gltf_builder import GltfBuilder

from viewer.scene.orientation import up_matrix
from viewer.splats import make_splats, transform_splats, write_ply
from viewer.splats.formats import write_splat
from viewer.splats.generate import sphere_splats

BOX_LO, BOX_HI = np.array([4.0, 1.0, -3.5]), np.array([6.0, 2.0, -2.5])
RED, BLUE, GREY, GREEN = (0.8, 0.1, 0.1), (0.1, 0.1, 0.8), (0.5, 0.5, 0.5), (0.1, 0.8, 0.1)
BALL_RADIUS = 0.6
OUTLIERS = 6


def box_gltf(path, lo=BOX_LO, hi=BOX_HI):
    """A closed box from ``lo`` to ``hi`` (far from the origin: framing must find it)."""
    b = GltfBuilder()
    corner = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], np.float32)
    pos = (lo + corner * (hi - lo)).astype(np.float32)
    idx = np.uint16([0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6,
                     0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3])
    b.mesh({"POSITION": b.accessor(pos, minmax=True)}, b.accessor(idx))
    return b.save(path)


def capture(seed: int = 0, outliers: int = OUTLIERS):
    """The splat capture in the scene's convention (+Y up): ground discs on y = 0 (x, z in
    [-2, 2]), the ball resting on it, ``outliers`` green splats 100-200 units away."""
    rng = np.random.default_rng(seed)
    g = np.linspace(-1.9, 1.9, 20)
    gx, gz = np.meshgrid(g, g)
    n = gx.size
    ground = make_splats(np.stack([gx.ravel(), np.zeros(n), gz.ravel()], -1),
                         np.tile([0.12, 0.12, 0.004], (n, 1)),
                         np.tile([np.sqrt(0.5), -np.sqrt(0.5), 0.0, 0.0], (n, 1)),  # z -> y
                         np.full(n, 0.95), albedo=np.tile(GREY, (n, 1)))
    ball = sphere_splats(600, radius=BALL_RADIUS, seed=seed)
    top = ball.means[:, 1:2] > 0
    ball = make_splats(ball.means + np.float32([0.0, BALL_RADIUS, 0.0]), ball.scales,
                       ball.rotations, ball.opacities,
                       albedo=np.where(top, RED, BLUE), normals=ball.normals)
    d = rng.normal(size=(outliers, 3))
    far = d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(100, 200, (outliers, 1))
    stray = make_splats(far, np.full((outliers, 3), 0.05), np.tile([1.0, 0, 0, 0], (outliers, 1)),
                        np.full(outliers, 0.9), albedo=np.tile(GREEN, (outliers, 1)))
    from viewer.splats import concat

    return concat([ground, ball, stray])


def to_file_convention(splats, up: str):
    """``splats`` (+Y up) as a file whose up is ``up`` stores them."""
    inverse = np.asarray(up_matrix(up), np.float64).T  # a rotation: its inverse
    return transform_splats(splats, inverse)


def capture_ply(path, up: str = "+Y", comments=(), **kw):
    write_ply(path, to_file_convention(capture(**kw), up), comments=comments)
    return path


def capture_splat(path, up: str = "-Y", **kw):
    """The capture as antimatter15 ``.splat`` records (baked colour, no normals)."""
    s = to_file_convention(capture(**kw), up)
    rgba = np.concatenate([np.round(s.albedo * 255), np.round(s.opacities[:, None] * 255)], 1)
    write_splat(path, s.means, s.scales, rgba.astype(np.uint8), s.rotations)
    return path
