"""The neural shadow estimator's GL passes (``passes/shadow_net_conv.comp``; thesis eq. 4.3).

:meth:`ShadowNetPass.run` dispatches every layer of a validated weights file
(:class:`viewer.neural.shadow_net.ShadowNetFile`, its :func:`~viewer.neural.shadow_net.plan`) over
the frame: the first reads the unshadowed radiance, the G-buffer's normals and depth and the SSAO
pass's occlusion and halves the resolution; the last multiplies the visibility it predicts into
the radiance in place (or, with ``visibility``, writes it to a map of its own: the parity checks).
Each layer's weights are one uniform block, uploaded once per file (:data:`MAX_NETWORKS` files
kept, least recently used released). The feature maps are the frame graph's
(:func:`map_sizes`); the pass allocates none.
"""
from __future__ import annotations

import numpy as np

from ..cache import BoundedCache
from ..gbuffer import GBufferLayout
from ..neural.shadow_net import (
    SOURCE_BILINEAR_UP,
    SOURCE_FRAME,
    SOURCE_NEAREST_UP,
    SOURCE_NONE,
    Layer,
    ShadowNetFile,
    len_packed,
    level_size,
    slices,
)
from . import bind_gbuffer
from . import set_uniform as _set

MAX_NETWORKS = 4
GROUP = 8  # local_size_x/y of passes/shadow_net_conv.comp


def map_sizes(net: ShadowNetFile, frame_size: tuple[int, int]) -> dict[str, tuple[int, int]]:
    """Layer name -> the texture size (W x slices, H) of the map it writes, for every layer but
    the last (which writes the radiance)."""
    return {layer.name: _tiled(layer, frame_size) for layer in net.layers[:-1]}


def _tiled(layer: Layer, frame_size) -> tuple[int, int]:
    w, h = level_size(frame_size, layer.level)
    return (w * slices(layer.out_channels), h)


class _Uploaded:
    """One file's per-layer uniform buffers."""

    def __init__(self, ctx, net: ShadowNetFile):
        self.buffers = {layer.name: ctx.buffer(np.ascontiguousarray(net.packed(layer),
                                                                    "<f4").tobytes())
                        for layer in net.layers}

    @property
    def nbytes(self) -> int:
        return sum(b.size for b in self.buffers.values())

    def release(self) -> None:
        for b in self.buffers.values():
            b.release()


class ShadowNetPass:
    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self._weights = BoundedCache("shadow estimator weights", max_items=MAX_NETWORKS,
                                     release=lambda u: u.release())

    def program(self, layer: Layer, visibility: bool = False):
        """The compute program of ``layer`` (its variant of ``passes/shadow_net_conv.comp``)."""
        last = layer.name == "out"
        return self.programs.compute("passes/shadow_net_conv.comp", defines={
            "SN_KERNEL": layer.kernel, "SN_STRIDE": layer.stride,
            "SN_A_SOURCE": layer.a_source, "SN_B_SOURCE": layer.b_source,
            "SN_A_SLICES": slices(layer.a_channels), "SN_B_SLICES": slices(layer.b_channels),
            "SN_OUT_SLICES": slices(layer.out_channels), "SN_ACT": layer.act,
            "SN_WEIGHTS": len_packed(layer), "SN_OUTPUT": int(last and not visibility),
            "SN_GAIN": f"{float(layer.gain):.9g}", "SN_ENV_VIS": int(layer.env_vis),
            "SN_DEMODULATE": int(layer.demodulate)},
            virtual=self.layout.virtual_files())

    def run(self, net: ShadowNetFile, gbuffer_textures: dict, radiance, ssao,
            maps: dict, frame_size: tuple[int, int], visibility=None,
            only: tuple[str, ...] | None = None, view_rotation=None) -> None:
        """Every layer of ``net`` (``only``: just those, reading the maps the others left):
        ``maps`` holds a texture of :func:`map_sizes` per layer; ``radiance`` (RGBA32F, frame
        size) is read by the first layer and multiplied by the visibility in place by the last,
        unless ``visibility`` (an RGBA32F texture of the frame's size) is given, which then
        receives the visibility instead (1 on the background is not applied: the raw map).
        ``view_rotation``: the camera's world -> view 3 x 3 rotation (None: the identity), which
        turns the G-buffer's world-space normals into the view-space normals the estimator
        reads (its training cameras look down -Z from the origin: view = world there)."""
        rotation = np.eye(3) if view_rotation is None else np.asarray(view_rotation)[:3, :3]
        rotation = np.ascontiguousarray(rotation.T, dtype="f4").tobytes()  # column-major
        uploaded = self._weights.get(net.checkpoint)
        if uploaded is None:
            uploaded = _Uploaded(self.ctx, net)
            self._weights.put(net.checkpoint, uploaded)
        frame_size = (int(frame_size[0]), int(frame_size[1]))
        for layer in net.layers:
            if only is not None and layer.name not in only:
                continue
            last = layer.name == "out"
            prog = self.program(layer, visibility is not None)
            out = (visibility if visibility is not None else radiance) if last \
                else maps[layer.name]
            _set(prog, "u_view_rotation", rotation)
            self._dispatch(prog, layer, uploaded.buffers[layer.name], gbuffer_textures,
                           radiance, ssao, maps, frame_size, out, write_radiance=last and
                           visibility is None)

    def _dispatch(self, prog, layer: Layer, buffer, gbuffer_textures, radiance, ssao, maps,
                  frame_size, out, write_radiance: bool) -> None:
        unit = 0
        frame = SOURCE_FRAME in (layer.a_source, layer.b_source)
        if frame:
            unit = bind_gbuffer(prog, gbuffer_textures)
            for name, tex in (("u_ssao", ssao),) + (() if write_radiance
                                                      else (("u_radiance", radiance),)):
                if name in prog:
                    tex.use(unit)
                    prog[name].value = unit
                    unit += 1
        elif write_radiance:
            unit = bind_gbuffer(prog, gbuffer_textures)
        for src, kind, level_of, uniform in ((layer.a, layer.a_source, "u_a_size", "u_a"),
                                             (layer.b, layer.b_source, "u_b_size", "u_b")):
            if kind in (SOURCE_NONE, SOURCE_FRAME):
                continue
            level = layer.level + (1 if kind in (SOURCE_NEAREST_UP, SOURCE_BILINEAR_UP)
                                   else -1 if layer.stride == 2 else 0)
            maps[src].use(unit)
            _set(prog, uniform, unit)
            _set(prog, level_of, level_size(frame_size, level))
            unit += 1
        _set(prog, "u_frame_size", frame_size)
        w, h = level_size(frame_size, layer.level)
        _set(prog, "u_out_size", (w, h))
        buffer.bind_to_uniform_block(0)
        prog["ShadowNetLayer"].binding = 0
        out.bind_to_image(0, read=write_radiance, write=True)
        _set(prog, "u_out", 0)
        self.ctx.memory_barrier()  # the previous layer's image stores before these fetches
        prog.run(-(-w // GROUP), -(-h // GROUP), 1)
        self.ctx.memory_barrier()

    def uploaded_bytes(self) -> int:
        return sum(u.nbytes for u in self._weights.values())

    def release(self) -> None:
        self._weights.clear()
