"""The shadow maps a lighting program reads, bound: the punctual lights' (``passes/lights.glsl``,
LIGHT_SHADOWS), the environment's sun's (SUN_SHADOW) and its other compact lights'
(``passes/env_lights.glsl``). Shared by the deferred lighting pass (:mod:`viewer.passes.shade`)
and the forward pass of transparent surfaces (:mod:`viewer.passes.forward`), which compile the
same lighting code. A light without a map gets a 1x1 map of depth 1 (its lens, or a matrix that
maps every point outside the map, says lit)."""
from __future__ import annotations

import math

import numpy as np

from ..lighting.cascades import MAX_CASCADES, ShadowCascades
from ..lighting.lights import as_lights
from ..lighting.shadow_frames import SHADOW_ORTHO
from . import set_uniform as _set


def shadow_lens(frame, size: float) -> tuple[float, float, float, float]:
    """``lib/shadow.glsl``'s lens of a shadow ``frame`` (kind, light-size scale, near, depth
    range; see ``shadow_penumbra_uv``): ``size`` is a directional light's angular radius
    (radians) or a point or spot light's radius (world units)."""
    if frame.kind == SHADOW_ORTHO:
        return (float(SHADOW_ORTHO), math.tan(min(max(size, 0.0), 0.3)) / max(frame.extent),
                0.0, float(frame.depth_range))
    # perspective: uv per unit of tangent is 1 / (2 tan(half-angle)) = 1 / extent
    return (float(frame.kind), float(size) / max(frame.extent), float(frame.near),
            float(frame.depth_range))


class ShadowBindings:
    """Binds a frame's shadow maps to a lighting program; owns the 1x1 map of lights without one."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._empty_shadow = None  # the 1x1 map bound for lights without a shadow

    def bind(self, prog, light, shadows: dict, sun_shadow: tuple | None, unit: int) -> int:
        """Bind the maps ``prog`` reads from texture ``unit`` on; returns the next free unit.
        ``shadows``: light index (or ``"env<k>"``) -> (map texture, frame, light size, normal
        offset) (:meth:`viewer.passes.shade.ShadePass.run`); ``sun_shadow``: the same for the
        environment's sun, or None."""
        unit = self._bind_shadows(prog, light, shadows, unit)
        unit = self._bind_env_light_shadows(prog, shadows, unit)
        unit = self._bind_env_shadows(prog, shadows.get("envdirs"), unit)
        return self._bind_sun_shadow(prog, sun_shadow, unit)

    def _bind_env_shadows(self, prog, entry, unit: int) -> int:
        """The environment's shadow directions (ENV_SHADOWS, ``passes/lights.glsl``
        ``env_shadow``): their atlas and per direction its tile's frame, direction and share,
        lens and normal offset. ``entry``: (atlas texture, EnvShadowFrames, softness, bias), or
        None (the 1x1 map of depth 1 and shares of 0: every direction skipped, unshadowed)."""
        if "u_env_shadow_dir" not in prog:
            return unit
        n = prog["u_env_shadow_dir"].array_length
        matrices = np.zeros((n, 4, 4), np.float32)
        dirs = np.zeros((n, 4), np.float32)
        lenses = np.zeros((n, 4), np.float32)
        offsets = np.zeros(n, np.float32)
        if entry is None:
            self._no_shadow().use(unit)
        else:
            tex, frames, softness, bias = entry
            tex.use(unit)
            for k, face in enumerate(frames.faces[:n]):
                matrices[k] = face.matrix.T
                dirs[k] = (*frames.directions[k], frames.shares[k])
                lenses[k] = shadow_lens(face, frames.penumbra_radius(k, softness))
                offsets[k] = face.texel_world * bias
        prog["u_env_shadow_map"].value = unit
        _set(prog, "u_env_shadow_matrix", matrices.tobytes())
        _set(prog, "u_env_shadow_dir", dirs.tobytes())
        _set(prog, "u_env_shadow_lens", lenses.tobytes())
        _set(prog, "u_env_shadow_offset", offsets.tobytes())
        return unit + 1

    def _bind_sun_shadow(self, prog, sun_shadow, unit: int) -> int:
        """The sun's map (SUN_SHADOW), or a map of depth 1 that every point falls outside."""
        if "u_sun_shadow_map" in prog:
            if sun_shadow is None:  # nothing casts one (an image stack alone): a map of depth 1
                self._no_shadow().use(unit)
                # every point maps to (-1, -1, -1): outside the map, so lit (shadow_visibility)
                matrix = np.zeros((4, 4))
                matrix[3] = (-1.0, -1.0, -1.0, 1.0)  # the translation column (column-major)
                normal, params = np.eye(3), (0.0, 1.0, 1.0, 0.0)
            else:
                tex, frame, angle, offset = sun_shadow
                tex.use(unit)
                matrix, normal = frame.matrix.T, np.linalg.inv(frame.matrix[:3, :3])
                params = (float(angle), float(frame.depth_range), float(max(frame.extent)),
                          float(offset))
            prog["u_sun_shadow_map"].value = unit
            unit += 1
            _set(prog, "u_sun_shadow_matrix", np.ascontiguousarray(matrix, np.float32).tobytes())
            _set(prog, "u_sun_shadow_normal_matrix",
                 np.ascontiguousarray(normal, np.float32).tobytes())
            _set(prog, "u_sun_shadow_params", params)
            if "u_sun_shadow_cascade_count" in prog:  # SUN_CASCADES: the sun's map is cascaded
                frame = sun_shadow[1]
                _set(prog, "u_sun_shadow_cascades", frame.uniforms().tobytes())
                _set(prog, "u_sun_shadow_cascade_count", int(frame.count))
        return unit

    def _bind_shadows(self, prog, light, shadows: dict, unit: int) -> int:
        """The shadow maps of ``lights.glsl`` (LIGHT_SHADOWS): one sampler per light, a 1x1 map
        of depth 1 where a light has none (its lens then says so)."""
        if "u_shadow_lens" not in prog:
            return unit
        n = len(as_lights(light))
        matrices = np.zeros((n, 4, 4), np.float32)
        lenses = np.zeros((n, 4), np.float32)
        offsets = np.zeros(n, np.float32)
        units = np.zeros(n, np.int32)
        cascades = np.zeros((n, MAX_CASCADES, 4), np.float32)
        counts = np.zeros(n, np.int32)  # 0: one map (shadow_light_visibility)
        for i in range(n):
            entry = shadows.get(i)
            tex = self._no_shadow() if entry is None else entry[0]
            tex.use(unit)
            units[i] = unit
            unit += 1
            if entry is not None:
                _, frame, size, offset = entry
                matrices[i] = frame.matrix.T  # column-major for GLSL
                lenses[i] = shadow_lens(frame, size)
                offsets[i] = offset
                if isinstance(frame, ShadowCascades):
                    cascades[i], counts[i] = frame.uniforms(), frame.count
        _set(prog, "u_shadow_map", units.tobytes())
        _set(prog, "u_shadow_matrix", matrices.tobytes())
        _set(prog, "u_shadow_lens", lenses.tobytes())
        _set(prog, "u_shadow_offset", offsets.tobytes())
        if "u_shadow_cascade_count" in prog:  # LIGHT_CASCADES
            _set(prog, "u_shadow_cascades", cascades.tobytes())
            _set(prog, "u_shadow_cascade_count", counts.tobytes())
        return unit

    def _bind_env_light_shadows(self, prog, shadows: dict, unit: int) -> int:
        """The environment's other lights' maps (passes/env_lights.glsl, ``shadows["env<k>"]``,
        as ``sun_shadow``); a map of depth 1 mapped outside (lit) where one is missing."""
        if "u_env_light_shadow_params" not in prog:
            return unit
        n = prog["u_env_light_shadow_params"].array_length
        matrices = np.zeros((n, 4, 4), np.float32)
        matrices[:, 3] = (-1.0, -1.0, -1.0, 1.0)  # no map: every point outside it, lit
        normals = np.tile(np.eye(3, dtype=np.float32), (n, 1, 1))
        params = np.tile(np.array([0.0, 1.0, 1.0, 0.0], np.float32), (n, 1))
        units = np.zeros(n, np.int32)
        for k in range(n):
            entry = shadows.get(f"env{k}")
            (self._no_shadow() if entry is None else entry[0]).use(unit)
            units[k], unit = unit, unit + 1
            if entry is not None:
                _, frame, angle, offset = entry
                matrices[k] = frame.matrix.T
                normals[k] = np.linalg.inv(frame.matrix[:3, :3])
                params[k] = (angle, frame.depth_range, max(frame.extent), offset)
        _set(prog, "u_env_light_shadow_map", units.tobytes())
        _set(prog, "u_env_light_shadow_matrix", matrices.tobytes())
        _set(prog, "u_env_light_shadow_normal_matrix", normals.tobytes())
        _set(prog, "u_env_light_shadow_params", params.tobytes())
        return unit

    def _no_shadow(self):
        if self._empty_shadow is None:
            self._empty_shadow = self.ctx.texture((1, 1), 1, np.ones(1, np.float32).tobytes(),
                                                  dtype="f4")
            self._empty_shadow.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
            self._empty_shadow.repeat_x = self._empty_shadow.repeat_y = False
        return self._empty_shadow

    def release(self) -> None:
        if self._empty_shadow is not None:
            self._empty_shadow.release()
            self._empty_shadow = None
