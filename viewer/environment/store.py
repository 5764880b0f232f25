"""Every environment a renderer uses, kept bounded in memory and cached on disk.

:class:`EnvironmentStore` owns, per environment, everything derived from it: the IBL (radiance
chain, prefiltered chain, irradiance map, SH), the IBL without its compact lights and the lights
(:func:`viewer.environment.sun.extract_lights`) where it has any, the importance-sampling tables (built on
first use) and the equal-power directions. One entry per environment, keyed by its description with intensity and rotation left out (they are
shader uniforms), sized by the real bytes of its textures and arrays, in a
:class:`viewer.cache.BoundedCache`: least recently used environments are evicted beyond
``max_bytes`` and their GL textures released at once. The DFG LUTs do not depend on the
environment: the store builds them once.

With ``IBLOptions.prefilter_method = "convolution"`` (the default) a new environment costs one
convolution on the CPU for both IBLs (:mod:`viewer.environment.ibl_build`), and what it computed is kept in the
disk cache (:mod:`viewer.environment.disk_cache`), keyed by the file's content: the same file in a new process
uploads the stored results instead of decoding and computing. ``"fis"`` builds two
importance-sampled chains with no disk cache: the bench's baseline.

A caller must not keep an IBL of an environment beyond the frame that asked for it (a later
environment may evict it); :meth:`EnvironmentStore.pinned` holds environments in use.
"""
from __future__ import annotations

import dataclasses
import time
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..cache import BoundedCache, Budgets, CacheStats, mib, texture_bytes
from ..imageio import pixel_type
from .disk_cache import EnvCache, _one_line, digest_key, file_digest
from .entry import Environment, level0
from .ibl import IBL, IBLOptions, build_ibl, build_luts, mip_sizes
from .ibl_build import build_environment_ibls
from .maps import DISPLAY_TYPES, EnvironmentSpec, load_environment
from .prefilter import level_widths, spectra_bytes
from .sampling import EnvSampling, build_env_sampling, median_cut, power_directions
from .sun import Sun, extract_lights

_DEFAULT = object()


class EnvironmentStore:
    """The environments of one GL context, bounded by ``max_bytes`` (LRU); see the module doc.

    ``options``: how IBLs are built (one set per store). ``disk``: an :class:`EnvCache`, None for
    none, or (default) the user's cache unless ``RELIGHT_ENV_CACHE=0``. ``progress(message)`` is
    called with a line per step while an environment is being built."""

    def __init__(self, programs, max_bytes: int | None = Budgets().environment_bytes,
                 options: IBLOptions = IBLOptions(), disk=_DEFAULT, progress=None):
        self.programs = programs
        self.options = options
        if disk is _DEFAULT:
            disk = EnvCache.from_environment() if options.prefilter_method == "convolution" \
                else None
        self.disk: EnvCache | None = disk
        self.progress = progress
        self._cache = BoundedCache("environments", max_bytes=max_bytes, release=Environment.release)
        self._lut_textures: tuple | None = None

    # ---- the interface GPUResources delegates to ------------------------------------------------
    def key(self, spec: EnvironmentSpec) -> tuple:
        """The entry of ``spec``: intensity and rotation are uniforms, so one precomputation
        serves every value of them."""
        return (dataclasses.replace(spec, intensity=1.0, rotation_deg=0.0), self.options)

    def ibl(self, spec: EnvironmentSpec, sun: bool = False) -> IBL:
        """The environment's IBL. ``sun=True``: the one whose prefiltered levels >= 1, irradiance
        map and SH leave out its compact lights (:func:`viewer.environment.sun.extract_lights`), for passes
        that shade them (``SUN_LIGHT``, ``ENV_LIGHTS``); the plain IBL where it has none."""
        entry = self._entry(spec)
        if sun and entry.sun is not None:
            built = entry._sunless is None and entry.ibls is None
            ibl = entry.sunless(self.programs, self.options)
            if built:
                self._resize(spec, entry)
            return ibl
        return entry.plain

    def sun(self, spec: EnvironmentSpec) -> Sun | None:
        """The environment's sun (its most energetic compact light), or None."""
        return self._entry(spec).sun

    def lights(self, spec: EnvironmentSpec) -> tuple[Sun, ...]:
        """Its compact lights (:func:`viewer.environment.sun.extract_lights`), the sun first, or ()."""
        return self._entry(spec).lights

    def env_sampling(self, spec: EnvironmentSpec) -> EnvSampling:
        """The environment's importance-sampling distribution (built on first use, on the GPU
        from the radiance texture, or read from the disk cache)."""
        entry = self._entry(spec)
        if entry.sampling is None:
            entry.sampling = self._sampling(entry)
            self._resize(spec, entry)
        return entry.sampling

    def power_directions(self, spec: EnvironmentSpec) -> np.ndarray:
        """The environment's equal-power directions (:func:`viewer.environment.sampling.power_directions`,
        environment frame ``[8, 3]``): computed on first use from the radiance texture's level 0
        (the loaded image, exactly), or read from the disk cache."""
        entry = self._entry(spec)
        if entry.power_directions is None:
            entry.power_directions = self._directions(entry)
            self._resize(spec, entry)
        return entry.power_directions

    def shadow_lights(self, spec: EnvironmentSpec, count: int, sunless: bool
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The environment's light as ``count`` directional lights that cast its shadows
        (:func:`viewer.environment.sampling.median_cut`: directions in the environment frame, shares,
        angular radii), of the image without its compact lights where ``sunless`` (the light
        the irradiance map holds when the compact lights are shaded analytically); computed on
        first use from the radiance texture's level 0."""
        entry = self._entry(spec)
        key = (int(count), bool(sunless and entry.lights))
        got = entry.shadow_lights.get(key)
        if got is None:
            env = level0(entry)
            if key[1]:
                env = extract_lights(env)[0]
            got = median_cut(env, key[0])
            entry.shadow_lights[key] = got
            self._resize(spec, entry)
        return got

    @property
    def environments(self) -> int:  # how many environments are held
        return len(self._cache)

    def stats(self) -> CacheStats:
        return self._cache.stats()

    def memory(self) -> dict:
        """What the store holds: the cache's stats, each environment's bytes, the shared LUTs,
        the process's kernel spectra (:mod:`viewer.environment.prefilter`) and the disk cache's stats."""
        return {"environments": self._cache.stats().as_dict(),
                "entries": [{"source": e.source, "bytes": e.nbytes,
                             "sampling": e.sampling is not None}
                            for e in self._cache.values()],
                "luts_bytes": sum(texture_bytes(t) for t in (self._lut_textures or ())),
                "kernel_spectra_bytes": spectra_bytes(),
                "disk": self.disk.stats() if self.disk is not None else None}

    @contextmanager
    def pinned(self, *specs: EnvironmentSpec):
        """Inside, the environments of ``specs`` are never evicted."""
        with self._cache.pinned(*(self.key(s) for s in specs)):
            yield self

    def resize(self, max_bytes: int | None) -> None:
        self._cache.resize(max_bytes=max_bytes)

    def release(self) -> None:
        """Free every environment's textures and the LUTs."""
        self._cache.clear()
        for tex in self._lut_textures or ():
            tex.release()
        self._lut_textures = None

    # ---- building ---------------------------------------------------------------------------
    def _entry(self, spec: EnvironmentSpec) -> Environment:
        key = self.key(spec)
        return self._cache.get_or_create(key, lambda: self._build(key[0]),
                                         nbytes=lambda e: e.nbytes)

    def _resize(self, spec, entry: Environment) -> None:
        self._cache.put(self.key(spec), entry, entry.nbytes)

    def _say(self, source: str, message: str, t0: float) -> None:
        if self.progress is not None:
            self.progress(f"environment {source}: {message} ({time.perf_counter() - t0:.2f} s)")

    def _luts(self) -> tuple:
        if self._lut_textures is None:
            key = digest_key("dfg", self.options.dfg_size, self.options.dfg_samples)
            n = int(self.options.dfg_size)
            got = self.disk.load(key, "dfg", {"dfg": (n, n, 2), "dominant": (n, n, 1)}) \
                if self.disk is not None else None
            ctx = self.programs.ctx
            if got is not None:
                import moderngl

                dfg = ctx.texture((n, n), 2, got[0]["dfg"].astype(np.float32), dtype="f4")
                dominant = ctx.texture((n, n), 1, got[0]["dominant"].astype(np.float32),
                                       dtype="f4")
                for tex in (dfg, dominant):
                    tex.repeat_x = tex.repeat_y = False
                    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            else:
                dfg, dominant = build_luts(self.programs, self.options)
                if self.disk is not None:
                    self.disk.save(key, "dfg", {
                        "dfg": np.frombuffer(dfg.read(), np.float32).reshape(n, n, 2),
                        "dominant": np.frombuffer(dominant.read(), np.float32).reshape(n, n, 1)},
                        {"dfg_size": n, "dfg_samples": int(self.options.dfg_samples)})
            self._lut_textures = (dfg, dominant)
        return self._lut_textures

    def _disk_key(self, spec: EnvironmentSpec) -> str | None:
        if self.disk is None:
            return None
        if spec.path is not None:
            if not Path(spec.path).is_file():
                return None  # load_environment reports it
            source = ("file", file_digest(spec.path))
            if pixel_type(spec.path) in DISPLAY_TYPES:  # sRGB-decoded: apart from entries
                source += ("srgb",)  # cached before 8-bit files were decoded (taken as linear)
        else:
            source = ("procedural", {k: v for k, v in dataclasses.asdict(spec).items()
                                     if k != "sun_strength"})
        if spec.sun_strength != 1.0:  # keys made before the setting stay valid at its default
            source += (("sun_strength", float(spec.sun_strength)),)
        return digest_key("environment", source, dataclasses.asdict(self.options))

    def _build(self, spec: EnvironmentSpec) -> Environment:
        t0 = time.perf_counter()
        source = Path(spec.path).name if spec.path is not None else f"{spec.procedural}"
        if self.options.prefilter_method != "convolution":
            env = load_environment(spec)
            residual, lights = extract_lights(env)
            plain = build_ibl(self.programs, env, self.options)
            self._say(source, "importance-sampled IBL", t0)
            return Environment(source, None, lights, plain=plain,
                               arrays=(env, residual) if lights else None)
        disk_key = self._disk_key(spec)
        cached = self._load(disk_key, spec) if disk_key is not None else None
        if cached is not None:
            env, patch, lights, parts = cached
            self._say(source, "read from the disk cache", t0)
        else:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                env = load_environment(spec)
            notes = [str(w.message) for w in caught]
            for w in caught:  # shown as they were, and kept for a later hit
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            residual, lights = extract_lights(env)
            parts = {"notes": notes}
            patch = None
            if lights:
                ys, xs = np.nonzero((env != residual).any(axis=-1))
                patch = (ys, xs, residual[ys, xs])
            self._say(source, f"loaded {env.shape[1]}x{env.shape[0]}", t0)
        ibls = build_environment_ibls(
            self.programs, env, self.options, sun=lights[0] if lights else None, sun_patch=patch,
            luts=self._luts(), cached=parts, keep=disk_key is not None and cached is None,
            progress=lambda step: self._say(source, step, t0), lights=lights)
        entry = Environment(source, ibls, lights, disk_key=disk_key)
        if cached is None and disk_key is not None:
            try:
                self._save(disk_key, env, patch, lights, ibls.parts, spec)
            except Exception as exc:  # noqa: BLE001 - the cache is an optimisation: say, go on
                warnings.warn(f"{self.disk.root}: environment {source} not cached "
                              f"({_one_line(exc)})", stacklevel=2)
            ibls.parts.pop("full_levels", None)  # kept on disk, not in memory
        return entry

    # ---- the disk cache ---------------------------------------------------------------------
    def _save(self, key: str, env, patch, lights, parts: dict, spec: EnvironmentSpec) -> None:
        arrays = {"env": env, "sh": np.asarray(parts["sh"], np.float32),
                  "irradiance": np.asarray(parts["irradiance"], np.float32)}
        for k, level in enumerate(parts["levels"], start=1):
            arrays[f"level{k}"] = np.asarray(level, np.float32)
        if lights:
            ys, xs, values = patch
            arrays.update(sun_rows=ys.astype(np.int64), sun_cols=xs.astype(np.int64),
                          sun_residual=np.asarray(values, np.float32),
                          sh_sunless=np.asarray(parts["sh_sunless"], np.float32),
                          irradiance_sunless=np.asarray(parts["irradiance_sunless"], np.float32))
            for k, level in enumerate(parts["full_levels"], start=1):
                arrays[f"full{k}"] = np.asarray(level, np.float32)
        meta = {"lights": [dataclasses.asdict(li) for li in lights],
                "notes": [_with_path(n, spec.path, _PATH) for n in parts.get("notes", [])],
                "levels": len(parts["levels"])}
        self.disk.save(key, "ibl", arrays, meta)

    def _load(self, key: str, spec: EnvironmentSpec):
        got = self.disk.load(key, "ibl", {"env": None, "sh": (9, 3), "irradiance": None})
        if got is None:
            return None
        arrays, meta = got
        env = arrays["env"]
        try:
            h, w = env.shape[:2]
            if env.ndim != 3 or env.shape[2] != 3 or w != 2 * h or w & (w - 1):
                raise ValueError(f"env has shape {env.shape}")
            width = max(w, int(self.options.prefilter_width))
            levels = max(1, min(int(self.options.prefilter_levels),
                                len(mip_sizes(width, width // 2))))
            widths = level_widths(width, int(self.options.prefilter_width), levels)
            parts = {"levels": [arrays[f"level{k}"] for k in range(1, levels)],
                     "sh": arrays["sh"], "irradiance": arrays["irradiance"],
                     "notes": meta.get("notes", [])}
            for k, lw in enumerate(widths, start=1):
                if parts["levels"][k - 1].shape != (max(1, lw // 2), lw, 3):
                    raise ValueError(f"level{k} has shape {parts['levels'][k - 1].shape}")
            patch, lights = None, ()
            if meta.get("lights"):
                lights = tuple(Sun(**{**f, "direction": tuple(f["direction"]),
                                      "irradiance": tuple(f["irradiance"])})
                               for f in meta["lights"])
                ys, xs, values = arrays["sun_rows"], arrays["sun_cols"], arrays["sun_residual"]
                if not (ys.shape == xs.shape == values.shape[:1] and values.shape[1:] == (3,)
                        and ys.min() >= 0 and ys.max() < h and xs.min() >= 0 and xs.max() < w):
                    raise ValueError("the lights' texels do not fit the image")
                patch = (ys, xs, values)
                parts.update(sh_sunless=arrays["sh_sunless"],
                             irradiance_sunless=arrays["irradiance_sunless"])
                parts["full_levels"] = [arrays[f"full{k}"] for k in range(1, levels)]
                for k in range(1, levels):
                    want = (max(1, (width >> k) // 2), max(1, width >> k), 3)
                    if parts["full_levels"][k - 1].shape != want:
                        raise ValueError(f"full{k} has shape {parts['full_levels'][k - 1].shape}")
        except (KeyError, ValueError, TypeError, IndexError) as exc:
            self.disk.reject(key, "ibl", f"does not fit this environment ({_one_line(exc)})")
            return None
        for note in parts["notes"]:  # what loading the file warned about, naming this path
            warnings.warn(_with_path(note, _PATH, spec.path), stacklevel=4)
        return env, patch, lights, parts

    def _directions(self, entry: Environment) -> np.ndarray:
        if entry.disk_key is not None and self.disk is not None:
            got = self.disk.load(entry.disk_key, "directions", {"power_directions": (8, 3)})
            if got is not None:
                return got[0]["power_directions"]
        directions = power_directions(level0(entry))
        if entry.disk_key is not None and self.disk is not None:
            self.disk.save(entry.disk_key, "directions",
                           {"power_directions": directions.astype(np.float32)}, {})
        return directions

    def _sampling(self, entry: Environment) -> EnvSampling:
        radiance = entry.plain.radiance
        w, h = radiance.width, radiance.height
        if entry.disk_key is not None and self.disk is not None:
            got = self.disk.load(entry.disk_key, "sampling",
                                 {"marginal": (h + 1,), "conditional": (h, w + 1), "pdf": (h, w)})
            if got is not None:
                arrays, meta = got
                return EnvSampling.from_arrays(self.programs.ctx, arrays["marginal"],
                                               arrays["conditional"], arrays["pdf"],
                                               bool(meta.get("fallback", False)))
        sampling = build_env_sampling(self.programs, radiance)
        if entry.disk_key is not None and self.disk is not None:
            self.disk.save(entry.disk_key, "sampling", sampling.read(),
                           {"fallback": bool(sampling.fallback)})
        return sampling

    def __repr__(self) -> str:
        s = self._cache.stats()
        return (f"EnvironmentStore({s.items} environments, {mib(s.bytes)} of "
                f"{mib(s.max_bytes)})")


# The file's path in a cached note: the cache is keyed by content, so a hit may come from a copy
# under another name; the note names the path loaded this time.
_PATH = "<environment file>"


def _with_path(note: str, old: str | None, new: str | None) -> str:
    return note.replace(str(old), str(new)) if old and new else note
