"""The generator's environments: a procedural sky or studio with a random sun, or one of the
configuration's files, at a random intensity and rotation (:func:`random_environment`), its
lower hemisphere a bright ground for a share of them (:func:`lambertian_ground`)."""
from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np

from viewer.environment.maps import EnvironmentSpec, load_environment, resample, texel_directions
from viewer.environment.sun import texel_solid_angles

from .config import PROCEDURAL_ENVIRONMENTS, GeneratorConfig, env_file

# the range of lambertian_ground's albedo (GeneratorConfig.ground_fraction): grass and concrete
# to snow
GROUND_ALBEDO = (0.2, 0.9)


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
    albedo = _ground_albedo(rng, config)
    if albedo is not None:
        env = lambertian_ground(env, albedo)
    intensity = float(rng.uniform(0.5, 1.5)) * (0.05 if pick == "sky" else 1.0) ** 0.5
    shift = int(rng.integers(0, env.shape[1]))  # a rotation about +Y by whole texels
    env = np.roll(env, shift, axis=1) * intensity
    recipe = {"source": pick, "intensity": intensity, "rotation_texels": shift}
    if sun != 1.0:
        recipe["sun_strength"] = sun
    if albedo is not None:
        recipe["ground_albedo"] = albedo
    return env.astype(np.float32), recipe


def _sun_strength(rng, config: GeneratorConfig) -> float:
    f = config.sunless_fraction
    if f <= 0.0:
        return 1.0
    if f >= 1.0:
        return 0.0
    return 0.0 if float(rng.random()) < f else 1.0



def _ground_albedo(rng, config: GeneratorConfig) -> float | None:
    """A ground albedo for ``config.ground_fraction`` of the draws (none drawn at 0)."""
    f = config.ground_fraction
    if f <= 0.0:
        return None
    if f < 1.0 and float(rng.random()) >= f:
        return None
    return float(rng.uniform(*GROUND_ALBEDO))


def lambertian_ground(env: np.ndarray, albedo: float) -> np.ndarray:
    """``env`` ``[H, W, 3]`` with its lower hemisphere replaced by a uniform Lambertian ground
    of ``albedo`` lit by the upper hemisphere: radiance albedo E_up / pi, E_up the upper
    hemisphere's irradiance on a surface facing up (its sun included), blended over the soft
    horizon band of the procedural sky (8 x the texel's -y). A surface facing down then sees
    albedo x E_up: ``env_below`` about ``albedo``."""
    h, w = env.shape[:2]
    y = texel_directions(w)[..., 1]
    dw = texel_solid_angles(h, w)[:, None]
    up = np.clip(y, 0.0, None) * dw
    e_up = (env * up[..., None]).sum((0, 1))
    ground = albedo * e_up / np.pi
    g = np.clip(-y * 8.0, 0.0, 1.0)[..., None]
    return (env * (1.0 - g) + ground * g).astype(np.float32)


@functools.lru_cache(maxsize=8)
def _file_environment(path: str, width: int, sun_strength: float = 1.0) -> np.ndarray:
    # a map without a compact light is sunless already: scale_sun says so once per file
    env = load_environment(EnvironmentSpec(path=path, width=width, sun_strength=sun_strength))
    env.setflags(write=False)
    return env
