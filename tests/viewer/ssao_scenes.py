"""Scenes and read-back shared by the SSAO tests (test_ssao.py, test_ssao_scale.py)."""
import numpy as np

from viewer.scene.description import scene_from_dict

SIZE = [48, 48]
FLOOR = {"type": "plane", "center": [0, 0, 0], "size": [8, 8], "normal": [0, 1, 0],
         "material": {"albedo": [0.8, 0.8, 0.8], "roughness": 0.8}}
WALL = {"type": "plane", "center": [0, 2, -1], "size": [8, 4], "normal": [0, 0, 1],
        "material": {"albedo": [0.9, 0.3, 0.2], "roughness": 0.8}}
SSAO = {"ssao_rays": 16, "ssao_steps": 8, "ssao_radius": 0.6, "ssao_thickness": 0.5}


def scene(objects, position=(0, 1.5, 2.5), target=(0, 0, -1), **render):
    return scene_from_dict({
        "camera": {"position": list(position), "target": list(target), "fov_y": 50,
                   "size": SIZE},
        "environment": {"procedural": "studio", "width": 64},
        "objects": objects,
        # the passes' own O(x), unblurred (the blur's tests set ssao_blur = true); no rays (they
        # stand in for SSAO and its bounce: tests/viewer/test_rt_light.py)
        "render": {"tonemap": "none", "ssao_blur": False, "raytrace": False, **render},
    })


def _read(targets, name):
    tex = getattr(targets, name)
    w, h = tex.size
    return np.frombuffer(tex.read(), np.float32).reshape(h, w, 4)[::-1].copy()
