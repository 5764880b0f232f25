"""The traced scene on the GPU: the buffers ``shaders/passes/raytrace.glsl`` reads, kept per set of
meshes in a bounded cache (:class:`TraceStore`), so a BVH is built and uploaded once for the
geometry it covers and again only when that geometry changes (a material slider re-uploads the
small material table, nothing else)."""
from __future__ import annotations

import time

import numpy as np

from ..cache import BoundedCache, CacheStats
from .scene import (
    ENTERED_ONLY,
    MAP_SIZE,
    MAPS,
    MATERIAL_VEC4S,
    ROW,
    TraceGeometry,
    build_trace_geometry,
    material_rows,
    slot_rows,
)
from .gather import traced_meshes

BINDINGS = (3, 4, 5)  # triangles, vertices, materials (raytrace.glsl's storage buffers)
# The traversal's nodes and triangle edges are RGBA32F textures of TEXEL_ROW texels a row
# (raytrace.glsl RT_TEXEL_ROW), read with texelFetch: llvmpipe fetches a texel for all 8 lanes
# at once where it reads a storage buffer lane by lane and component by component, each
# bounds-checked (Mesa 22.3).
TEXEL_ROW = 4096


class TraceBuffers:
    """One :class:`~viewer.raytrace.scene.TraceGeometry` uploaded: SSBOs and the map array."""

    def __init__(self, ctx, geometry: TraceGeometry):
        self.ctx = ctx
        self.geometry = geometry
        self.node_count = int(geometry.nodes.shape[0])
        self.nodes = _texels(ctx, geometry.nodes)
        self.edges = _texels(ctx, geometry.edges)
        self.splats = _texels(ctx, geometry.splats)  # 4 texels a splat (splat_proxies.splat_rows)
        self.triangles = ctx.buffer(_bytes(geometry.triangles))
        self.vertices = ctx.buffer(_bytes(geometry.vertices))
        self.materials = ctx.buffer(reserve=16)
        self._material_key = None
        self.defines = {"RT_MASKS": 1, "RT_MAPS": (1 << len(MAPS)) - 1,
                        "RT_SPLATS": 1}  # set_materials
        self._slots = None  # slot_rows of the meshes: fixed for these meshes' geometry
        layers = max(int(geometry.maps.shape[0]), 1)
        data = (geometry.maps.astype(np.float16) if geometry.maps.shape[0]
                else np.ones((1, MAP_SIZE, MAP_SIZE, 4), np.float16))
        self.maps = ctx.texture_array((MAP_SIZE, MAP_SIZE, layers), 4, data.tobytes(), dtype="f2")
        self.maps.repeat_x = self.maps.repeat_y = False  # wrap modes: rt_map_uv
        self.seconds = geometry.bvh.seconds

    @property
    def nbytes(self) -> int:
        return int(self.triangles.size + self.vertices.size + self.materials.size
                   + 16 * self.nodes.width * self.nodes.height
                   + 16 * self.edges.width * self.edges.height
                   + 16 * self.splats.width * self.splats.height
                   + self.maps.width * self.maps.height * self.maps.layers * 8)

    def set_materials(self, meshes) -> None:
        """Upload the meshes' materials when they changed since the last call (sliders)."""
        if self._slots is None or self._slots.shape[0] != max(len(meshes), 1):
            self._slots = slot_rows(meshes, self.geometry.layers)
        rows = material_rows(meshes, self.geometry.layers, self._slots)
        key = rows.tobytes()
        if key != self._material_key:
            if self.materials.size != len(key):
                self.materials.orphan(len(key))
            self.materials.write(key)
            self._material_key = key
            self.defines = material_defines(rows)

    def bind(self, prog, unit: int) -> int:
        """Bind the buffers to raytrace.glsl's points, the node and edge textures and the map
        array to texture units from ``unit``; returns the next free unit."""
        for buf, point in zip((self.triangles, self.vertices, self.materials), BINDINGS):
            buf.bind_to_storage_buffer(point)
        for name, tex in (("u_rt_nodes", self.nodes), ("u_rt_edges", self.edges),
                          ("u_rt_splats", self.splats)):
            if name in prog:
                tex.use(unit)
                prog[name].value = unit
                unit += 1
        if "u_rt_maps" in prog:
            self.maps.use(unit)
            prog["u_rt_maps"].value = unit
            unit += 1
        if "u_rt_node_count" in prog:
            prog["u_rt_node_count"].value = self.node_count
        return unit

    def release(self) -> None:
        for obj in (self.nodes, self.triangles, self.vertices, self.edges, self.splats,
                    self.materials, self.maps):
            obj.release()


class TraceStore:
    """Traced scenes by the meshes they hold (and the geometry cache's version), at most
    ``max_bytes`` of GPU memory (least recently used released first)."""

    def __init__(self, ctx, max_bytes: int | None):
        self.ctx = ctx
        self._cache = BoundedCache("traced scenes", max_bytes=max_bytes,
                                   release=lambda b: b.release())
        self.build_seconds = 0.0  # the last build's time (the bench reads it)

    def get(self, contents, version: int) -> TraceBuffers:
        """The traced scene of ``(obj, content)`` pairs, materials as they are now."""
        meshes = traced_meshes(contents)
        key = (version, tuple(id(m) for m in meshes))

        def build():
            t0 = time.perf_counter()
            buffers = TraceBuffers(self.ctx, build_trace_geometry(meshes))
            self.build_seconds = time.perf_counter() - t0
            return buffers
        buffers = self._cache.get_or_create(key, build, nbytes=lambda b: b.nbytes)
        buffers.set_materials(meshes)
        return buffers

    def stats(self) -> CacheStats:
        return self._cache.stats()

    def resize(self, max_bytes: int | None) -> None:
        self._cache.resize(max_bytes)

    def release(self) -> None:
        self._cache.clear()


def material_defines(rows: np.ndarray) -> dict:
    """What ``rows`` (:func:`~viewer.raytrace.scene.material_rows`) use, as raytrace.glsl's
    defines: ``RT_MASKS`` (some material is alphaMode MASK, a cutoff >= 0), ``RT_SPLATS`` (some
    mesh is a splat proxy, :data:`~viewer.raytrace.scene.ENTERED_ONLY`: the splats' Gaussians are
    evaluated) and ``RT_MAPS`` (bit k: some material has a map in slot k), so a pass compiles
    out what no material needs."""
    per = rows.reshape(-1, MATERIAL_VEC4S, 4)
    cutoff = per[:, ROW["surface"], 3]
    masks = bool((cutoff >= 0.0).any())
    layers = per[:, ROW["slots"]::2, 3]  # each slot's layer, -1: none
    bits = sum(1 << k for k in range(len(MAPS)) if (layers[:, k] >= 0.0).any())
    splats = bool((cutoff == ENTERED_ONLY).any())
    return {"RT_MASKS": int(masks), "RT_MAPS": int(bits), "RT_SPLATS": int(splats)}


def _texels(ctx, a: np.ndarray):
    """``a`` (float32, 4 a texel in row-major order) as an RGBA32F texture of TEXEL_ROW texels a
    row (the last row padded with zeros; at least one texel)."""
    flat = np.ascontiguousarray(a, np.float32).reshape(-1, 4)
    width = min(TEXEL_ROW, max(len(flat), 1))
    rows = max(-(-len(flat) // width), 1)
    data = np.zeros((rows * width, 4), np.float32)
    data[:len(flat)] = flat
    tex = ctx.texture((width, rows), 4, data.tobytes(), dtype="f4")
    tex.filter = (ctx.NEAREST, ctx.NEAREST)
    tex.repeat_x = tex.repeat_y = False
    return tex


def _bytes(a: np.ndarray) -> bytes:
    data = np.ascontiguousarray(a).tobytes()
    return data if data else bytes(16)  # a GL buffer holds at least something
