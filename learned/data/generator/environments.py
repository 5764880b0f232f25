"""The generator's environments: a procedural sky or studio with a random sun, or one of the
configuration's files, at a random intensity and rotation (:func:`random_environment`)."""
from __future__ import annotations

import functools

import numpy as np

from viewer.environment.maps import EnvironmentSpec, load_environment, resample

from .config import PROCEDURAL_ENVIRONMENTS, GeneratorConfig, env_file


def random_environment(rng, config: GeneratorConfig) -> tuple[np.ndarray, dict]:
    """An equirect ``[H, W, 3]`` radiance image (intensity and rotation baked) and its recipe."""
    choices = list(config.env_procedural) + list(config.env_paths)
    pick = choices[int(rng.integers(0, len(choices)))]
    if pick in PROCEDURAL_ENVIRONMENTS:
        spec = EnvironmentSpec(procedural=pick, width=config.env_width,
                               sun_elevation_deg=float(rng.uniform(10.0, 70.0)),
                               sun_azimuth_deg=float(rng.uniform(-180.0, 180.0)))
        env = load_environment(spec)
    else:  # a file: loaded (and its texel warnings given) once per process
        env = _file_environment(str(env_file(pick)), config.env_width)
    if env.shape[1] != config.env_width:

        env = resample(env, config.env_width, config.env_width // 2)
    intensity = float(rng.uniform(0.5, 1.5)) * (0.05 if pick == "sky" else 1.0) ** 0.5
    shift = int(rng.integers(0, env.shape[1]))  # a rotation about +Y by whole texels
    env = np.roll(env, shift, axis=1) * intensity
    return env.astype(np.float32), {"source": pick, "intensity": intensity,
                                    "rotation_texels": shift}


@functools.lru_cache(maxsize=8)
def _file_environment(path: str, width: int) -> np.ndarray:
    env = load_environment(EnvironmentSpec(path=path, width=width))
    env.setflags(write=False)
    return env
