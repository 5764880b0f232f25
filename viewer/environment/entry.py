"""One environment's derived data, an entry of :class:`viewer.environment.store.EnvironmentStore`:
its IBLs (with and without its compact lights), the lights themselves, importance-sampling
tables and equal-power directions, with the bytes they hold and their release."""
from __future__ import annotations

import numpy as np

from ..cache import array_bytes, texture_bytes
from .ibl import IBL, IBLOptions, build_ibl
from .ibl_build import EnvironmentIBLs
from .sampling import EnvSampling
from .sun import Sun


class Environment:
    """One environment's derived data (an entry of :class:`EnvironmentStore`)."""

    def __init__(self, source: str, ibls: EnvironmentIBLs | None, lights: tuple[Sun, ...],
                 directions: np.ndarray | None = None, disk_key: str | None = None,
                 plain: IBL | None = None, arrays: tuple | None = None):
        self.source = source              # the file or procedural name (for memory reports)
        self.ibls = ibls                  # "convolution": both IBLs and their textures
        self.lights = tuple(lights)       # its compact lights (viewer.environment.sun.extract_lights)
        self.sun = self.lights[0] if self.lights else None  # the most energetic one
        self.power_directions = directions  # None until asked for (EnvironmentStore)
        # (count, sunless) -> median_cut's arrays: the shadow directions (EnvironmentStore)
        self.shadow_lights: dict[tuple[int, bool], tuple[np.ndarray, ...]] = {}
        self.disk_key = disk_key          # the disk cache's key, or None
        self.sampling: EnvSampling | None = None
        # "fis": the plain IBL, the sun-less one built on first use from the (env, residual) kept
        self._plain = plain
        self._sunless: IBL | None = None
        self._arrays = arrays

    @property
    def plain(self) -> IBL:
        return self.ibls.plain if self.ibls is not None else self._plain

    def sunless(self, programs, options: IBLOptions) -> IBL | None:
        """The IBL without its lights (None without any); "fis" builds it now."""
        if self.sun is None:
            return None
        if self.ibls is not None:
            return self.ibls.sunless
        if self._sunless is None:
            env, residual = self._arrays
            ibl = build_ibl(programs, env, options, sun=self.sun, residual=residual,
                            lights=self.lights)
            ibl.full_prefiltered = self._plain.prefiltered  # owned by the plain IBL
            self._sunless = ibl
        return self._sunless

    def textures(self) -> list:
        out = list(self.ibls.textures) if self.ibls is not None else []
        for ibl in (self._plain, self._sunless):
            if ibl is not None:
                out += list(ibl._owned)
        if self.sampling is not None:
            out += [self.sampling.marginal, self.sampling.conditional, self.sampling.pdf]
        return [t for t in out if t is not None]

    @property
    def nbytes(self) -> int:
        sh = [self.plain.sh] + ([] if self.ibls is None or self.ibls.sunless is None
                                else [self.ibls.sunless.sh])
        return (sum(texture_bytes(t) for t in self.textures())
                + array_bytes(self.power_directions, sh, self._arrays)
                + sum(a.nbytes for v in self.shadow_lights.values() for a in v))

    def release(self) -> None:
        if self.ibls is not None:
            self.ibls.release()
        for ibl in (self._plain, self._sunless):
            if ibl is not None:
                ibl.release()
        if self.sampling is not None:
            self.sampling.release()
        self.ibls = self._plain = self._sunless = self.sampling = None
        self._arrays = None


def level0(entry: Environment) -> np.ndarray:
    """The environment's radiance texture's level 0 (the loaded image, exactly), ``[H, W, 3]``
    float32, read back once for what is computed from it on first use."""
    radiance = entry.plain.radiance
    return np.frombuffer(radiance.read(), np.float32).reshape(
        radiance.height, radiance.width, 4)[..., :3]
