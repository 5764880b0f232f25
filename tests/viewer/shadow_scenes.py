"""The sphere-above-a-floor scene shared by the shadow tests (test_shadows.py,
test_shadows_positional.py): a camera looking straight down at the floor, the sphere's world
geometry, each pixel's floor point and the pixels the sphere hides."""
import numpy as np

N = 128
HEIGHT, FOV = 6.0, 60.0  # a camera looking straight down at the floor
CENTER, RADIUS = np.array([0.0, 1.0, 0.0]), 0.5
FLOOR = {"type": "plane", "center": [0, 0, 0], "size": [10, 10], "normal": [0, 1, 0],
         "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.9}}
SPHERE = {"type": "sphere", "center": CENTER.tolist(), "radius": RADIUS}
# the scene file's camera and black environment: every test adds its lights, objects and render
CAMERA = {"position": [0, HEIGHT, 0], "target": [0, 0, 0], "up": [0, 0, -1], "fov_y": FOV,
          "size": [N, N]}
DARK = {"procedural": "white", "width": 32, "intensity": 0.0}


def floor_points():
    """World (x, z) of every pixel's floor point (row 0 at the top): the camera looks down -Y
    with +X to the right and -Z up the image (up = -Z)."""
    half = HEIGHT * np.tan(np.radians(FOV) / 2.0)
    c = (np.arange(N) + 0.5) / N * 2.0 - 1.0
    return np.broadcast_to(c[None, :] * half, (N, N)), np.broadcast_to(c[:, None] * half, (N, N))


def sphere_pixels(x, z):
    """Pixels whose view ray (straight down, near enough) meets the sphere first."""
    return (x - CENTER[0]) ** 2 + (z - CENTER[2]) ** 2 < (RADIUS * 1.25) ** 2
