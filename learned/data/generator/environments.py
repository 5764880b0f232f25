"""The generator's environments: a procedural sky or studio with a random sun, or one of the
configuration's files, at a random intensity and rotation (:func:`random_environment`)."""
from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np

from viewer.environment.maps import EnvironmentSpec, load_environment, resample

from .config import PROCEDURAL_ENVIRONMENTS, GeneratorConfig, env_file


def random_environment(rng, config: GeneratorConfig) -> tuple[np.ndarray, dict]:
    """An equirect ``[H, W, 3]`` radiance image (intensity and rotation baked) and its recipe;
    sunless (``sun_strength`` 0) for ``config.sunless_fraction`` of the draws (a draw of its own
    only when the fraction is strictly between 0 and 1, so 0 and 1 give the same scenes)."""
    choices = list(config.env_procedural) + list(config.env_paths)
    pick = choices[int(rng.integers(0, len(choices)))]
    sun = 1.0
    if pick in PROCEDURAL_ENVIRONMENTS:
        spec = EnvironmentSpec(procedural=pick, width=config.env_width,
                               sun_elevation_deg=float(rng.uniform(10.0, 70.0)),
                               sun_azimuth_deg=float(rng.uniform(-180.0, 180.0)))
        sun = _sun_strength(rng, config)
        env = load_environment(replace(spec, sun_strength=sun))
    else:  # a file: loaded (and its texel warnings given) once per process
        sun = _sun_strength(rng, config)
        env = _file_environment(str(env_file(pick)), config.env_width, sun)
    if env.shape[1] != config.env_width:

        env = resample(env, config.env_width, config.env_width // 2)
    intensity = float(rng.uniform(0.5, 1.5)) * (0.05 if pick == "sky" else 1.0) ** 0.5
    shift = int(rng.integers(0, env.shape[1]))  # a rotation about +Y by whole texels
    env = np.roll(env, shift, axis=1) * intensity
    recipe = {"source": pick, "intensity": intensity, "rotation_texels": shift}
    if sun != 1.0:
        recipe["sun_strength"] = sun
    return env.astype(np.float32), recipe


def _sun_strength(rng, config: GeneratorConfig) -> float:
    f = config.sunless_fraction
    if f <= 0.0:
        return 1.0
    if f >= 1.0:
        return 0.0
    return 0.0 if float(rng.random()) < f else 1.0



@functools.lru_cache(maxsize=8)
def _file_environment(path: str, width: int, sun_strength: float = 1.0) -> np.ndarray:
    # a map without a compact light is sunless already: scale_sun says so once per file
    env = load_environment(EnvironmentSpec(path=path, width=width, sun_strength=sun_strength))
    env.setflags(write=False)
    return env
