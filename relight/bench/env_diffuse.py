"""``relight bench``'s environment suite, diffuse rows: a flat Lambertian floor (and every normal
of the upper hemisphere) under each real HDRI of ``assets/environments``, the diffuse irradiance
each method shades against the exact cosine convolution of the same map (the sum over every
texel, :func:`viewer.environment.irradiance.irradiance_brute`).

Methods, with the passes' arithmetic (their torch twins, which the tests hold to the GL passes):

* ``SH9 + 1 sun (before)``: the most energetic compact light taken out (:func:`viewer.environment.sun.
  extract_sun`) and shaded as a point light, max(n.l, 0) E; the rest projected on 9 SH
  coefficients (Ramamoorthi & Hanrahan 2001), what every model shaded before the irradiance map.
* ``irradiance map + lights``: up to 4 compact lights taken out (:func:`viewer.environment.sun.extract_lights`)
  and shaded as discs cut by the horizon (``disc_light``), the rest from the exact irradiance map
  (:func:`viewer.environment.irradiance.irradiance_map`, ``irradiance_lookup``).

Alone: ``python -m relight.bench.env_diffuse`` (a table on stdout).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ASSETS = Path(__file__).resolve().parents[2] / "assets" / "environments"
_LUMA = np.array([0.2126, 0.7152, 0.0722])


def _normals(count: int = 2000, seed: int = 0) -> np.ndarray:
    """The floor's normal (+Y) first, then ``count`` random ones of the upper hemisphere."""
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(count, 3))
    n[:, 1] = np.abs(n[:, 1])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.concatenate([[[0.0, 1.0, 0.0]], n])


def _sh9(env: np.ndarray) -> np.ndarray:
    """``[9, 3]`` radiance SH of ``env`` over every texel (exact texel solid angles)."""
    import torch

    from learned.twins.sh import sh_basis_all
    from viewer.environment.maps import texel_directions
    from viewer.environment.sun import texel_solid_angles

    h, w = env.shape[:2]
    d = torch.from_numpy(texel_directions(w).reshape(-1, 3).astype(np.float64))
    basis = sh_basis_all(d).numpy()  # [N, 9]
    weighted = (env.astype(np.float64) * texel_solid_angles(h, w)[:, None, None]).reshape(-1, 3)
    return basis.T @ weighted


def diffuse_methods(env: np.ndarray, normals: np.ndarray) -> dict[str, tuple[np.ndarray, int]]:
    """Method name -> (irradiance ``[N, 3]`` at ``normals``, lights taken out)."""
    import torch

    from learned.twins.ibl import irradiance_lookup
    from learned.twins.sh import sh_irradiance
    from learned.twins.shading import disc_light
    from viewer.environment.irradiance import IRRADIANCE_WIDTH, irradiance_map
    from viewer.environment.sun import extract_lights, extract_sun

    n32 = torch.from_numpy(normals.astype(np.float32))
    out = {}
    residual, sun = extract_sun(env)
    with torch.no_grad():
        e = sh_irradiance(n32, torch.from_numpy(_sh9(residual).astype(np.float32))).double().numpy()
    if sun is not None:
        e += np.maximum(normals @ np.asarray(sun.direction), 0.0)[:, None] \
            * np.asarray(sun.irradiance)
    out["SH9 + 1 sun (before)"] = (e, int(sun is not None))
    residual, lights = extract_lights(env)
    irr = irradiance_map(residual, min(IRRADIANCE_WIDTH, env.shape[1]))
    with torch.no_grad():
        e = irradiance_lookup(torch.from_numpy(irr), n32).double().numpy()
        for li in lights:
            d = disc_light(n32, torch.tensor(li.direction, dtype=torch.float32).expand_as(n32),
                           torch.full((len(normals),), float(li.angular_radius))).double().numpy()
            e += (d[:, 3] * (normals * d[:, :3]).sum(-1))[:, None] * np.asarray(li.irradiance)
    out["irradiance map + lights"] = (e, len(lights))
    return out


def diffuse_rows(paths=None) -> list[dict]:
    """One row per (map, method): the floor's error and the largest over the hemisphere, in %
    of the exact convolution (luminance)."""
    from viewer.environment.irradiance import irradiance_brute
    from viewer.environment.maps import EnvironmentSpec, load_environment

    rows = []
    normals = _normals()
    for path in paths if paths is not None else sorted(ASSETS.glob("*.exr")):
        env = load_environment(EnvironmentSpec(path=str(path)))
        truth = irradiance_brute(env, normals) @ _LUMA
        for method, (e, lights) in diffuse_methods(env, normals).items():
            err = (e @ _LUMA - truth) / truth
            rows.append({"case": "diffuse vs exact convolution", "map": Path(path).name,
                         "method": method, "lights": lights,
                         "floor_err_pct": 100.0 * float(err[0]),
                         "max_abs_err_pct": 100.0 * float(np.abs(err).max())})
    return rows


def main() -> int:
    import warnings

    warnings.simplefilter("ignore")  # the files' clamped texels: reported by the loader
    rows = diffuse_rows()
    keys = ("map", "method", "lights", "floor_err_pct", "max_abs_err_pct")
    print("| " + " | ".join(keys) + " |\n|" + "---|" * len(keys))
    for r in rows:
        print("| " + " | ".join(f"{r[k]:+.2f}" if isinstance(r[k], float) else str(r[k])
                                for k in keys) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
