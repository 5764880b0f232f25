"""The headless deferred renderer: scene -> G-buffer -> lighting -> tone mapping.

    from viewer import Renderer, load_scene
    renderer = Renderer()                       # headless EGL (llvmpipe without a GPU)
    scene = load_scene("assets/scenes/demo.toml")
    frame = renderer.render(scene, aovs=("normal", "depth"))
    frame.radiance   # [H, W, 4] float32: linear RGB before exposure/tone mapping, alpha = coverage
    frame.display    # [H, W, 4] uint8: exposed, tone-mapped, sRGB-encoded
    frame.aovs["normal"]
    frame2 = renderer.render(scene.with_render(exposure=1.0))   # cached: only the last passes rerun

GPU resources are cached by value: geometry per object description, IBL precomputation per
environment (intensity and rotation are uniforms, so light sliders never recompute), render targets
per size and layout, programs per variant. Arrays are row 0 at the top.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .camera import Camera
from .errors import InputError, SceneError
from .gbuffer import CHANNEL_NAMES, GBufferLayout
from .gl import ContextOptions, Programs, create_context, make_current
from .models import model_info
from .scene import ObjectSpec, Scene

AOV_NAMES = CHANNEL_NAMES  # albedo, alpha, normal, roughness, metallic, specular, ao, depth, color


@dataclass
class Frame:
    """What one render produced, read back to numpy (row 0 at the top)."""

    radiance: np.ndarray  # [H, W, 4] float32 linear radiance, alpha = coverage
    display: np.ndarray  # [H, W, 4] uint8 sRGB after exposure and tone mapping
    aovs: dict[str, np.ndarray] = field(default_factory=dict)  # [H, W, C] float32 each
    camera: Camera | None = None


class Renderer:
    """Owns one GL context and every GPU resource derived from scenes rendered with it."""

    def __init__(self, ctx=None, options: ContextOptions = ContextOptions()):
        self._owns_context = ctx is None
        self.ctx = ctx if ctx is not None else create_context(options)
        self.programs = Programs(self.ctx)
        self._geometry: dict[ObjectSpec, object] = {}
        self._ibl: dict[tuple, object] = {}
        self._targets: dict[tuple, dict] = {}
        self._gbuffer_passes: dict[GBufferLayout, object] = {}
        self._shade_passes: dict[GBufferLayout, object] = {}
        self._tonemap = None

    # ---- scene content ------------------------------------------------------------------------
    def geometry(self, obj: ObjectSpec):
        """CPU geometry for an object: a list of meshes, or an image-space G-buffer."""
        if obj not in self._geometry:
            self._geometry[obj] = _load_object(obj)
        return self._geometry[obj]

    def resolve_camera(self, scene: Scene, size: tuple[int, int] | None = None) -> Camera:
        """The scene's camera, or the camera of its image-space G-buffer stack."""
        stacks = [self.geometry(o) for o in scene.objects if o.type == "gbuffer"]
        camera = scene.camera
        if stacks:
            sizes = {s.size for s in stacks}
            if len(sizes) > 1:
                raise SceneError(f"image-space G-buffers of different sizes {sorted(sizes)} in one "
                                 f"scene", where=scene.source)
            stack = stacks[0]
            camera = Camera(position=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0),
                            fov_y=stack.fov_y, size=stack.size, near=scene.camera.near,
                            far=max(scene.camera.far, 1e4))
            if size is not None and tuple(size) != tuple(stack.size):
                raise SceneError(f"an image-space G-buffer renders at its own size "
                                 f"{stack.size[0]}x{stack.size[1]}, not {size[0]}x{size[1]}",
                                 where=scene.source)
        elif size is not None:
            camera = camera.with_size(*size)
        return camera

    def layout_for(self, scene: Scene) -> GBufferLayout:
        """Only the channels the scene needs: the baked-colour channel exists with splats only."""
        return GBufferLayout(with_color=any(o.type == "splats" for o in scene.objects))

    def ibl(self, scene: Scene):
        from .environment import load_environment
        from .ibl import IBLOptions, build_ibl

        spec = dataclasses.replace(scene.environment, intensity=1.0, rotation_deg=0.0)
        key = (spec, IBLOptions())
        if key not in self._ibl:
            env = load_environment(spec)
            self._ibl[key] = build_ibl(self.programs, env, IBLOptions())
        return self._ibl[key]

    def _target_set(self, layout: GBufferLayout, size: tuple[int, int]) -> dict:
        from .passes.gbuffer import GBufferTargets

        key = (layout, tuple(size))
        if key not in self._targets:
            ctx = self.ctx
            radiance = ctx.texture(size, 4, dtype="f4")
            display = ctx.texture(size, 4, dtype="f1")
            for t in (radiance, display):
                t.filter = (ctx.NEAREST, ctx.NEAREST)
            self._targets[key] = {
                "gbuffer": GBufferTargets.create(ctx, layout, size),
                "radiance": radiance,
                "radiance_fbo": ctx.framebuffer(color_attachments=[radiance]),
                "display": display,
                "display_fbo": ctx.framebuffer(color_attachments=[display]),
            }
        return self._targets[key]

    # ---- rendering --------------------------------------------------------------------------
    def draw(self, scene: Scene, size: tuple[int, int] | None = None, **kwargs) -> dict:
        """Run every pass on the GPU; no readback. Returns the target set (textures, framebuffers).

        The renderer's context is made current first, so several renderers and contexts can live
        in one process.
        """
        make_current(self.ctx)
        return self._draw(scene, size, **kwargs)

    def _draw(self, scene: Scene, size: tuple[int, int] | None = None) -> dict:
        """Run every pass on the GPU; no readback. Returns the target set (textures, framebuffers)."""
        from .passes.gbuffer import GBufferPass
        from .passes.shade import ShadePass
        from .passes.tonemap import TonemapPass

        settings = scene.render
        model_info(settings.model)  # unknown model -> SceneError before any GPU work
        if any(o.type == "splats" for o in scene.objects):
            raise SceneError("objects of type 'splats' are not supported by this version yet",
                             where=scene.source)
        camera = self.resolve_camera(scene, size)
        layout = self.layout_for(scene)
        targets = self._target_set(layout, camera.size)
        gpass = self._gbuffer_passes.get(layout)
        if gpass is None:
            gpass = self._gbuffer_passes[layout] = GBufferPass(self.programs, layout)
        gb = targets["gbuffer"]
        gb.clear()
        meshes = []
        for obj in scene.objects:
            content = self.geometry(obj)
            if obj.type == "gbuffer":
                gpass.draw_image(gb, content)
            else:
                meshes.extend(content)
        if meshes:
            gpass.draw_meshes(gb, camera, meshes)
        spass = self._shade_passes.get(layout)
        if spass is None:
            spass = self._shade_passes[layout] = ShadePass(self.programs, layout)
        spass.run(gb.textures, targets["radiance_fbo"], camera, self.ibl(scene), scene.environment,
                  settings)
        if self._tonemap is None:
            self._tonemap = TonemapPass(self.programs)
        self._tonemap.run(targets["radiance"], targets["display_fbo"], settings.exposure,
                          settings.tonemap)
        targets["camera"] = camera
        return targets

    def render(self, scene: Scene, aovs: tuple[str, ...] | list[str] = (),
               size: tuple[int, int] | None = None) -> Frame:
        """Render ``scene`` and read back radiance, display pixels and the requested AOVs."""
        make_current(self.ctx)
        return self._render(scene, aovs, size)

    def _render(self, scene: Scene, aovs: tuple[str, ...] | list[str] = (),
                size: tuple[int, int] | None = None) -> Frame:
        """Render ``scene`` and read back radiance, display pixels and the requested AOVs."""
        unknown = [a for a in aovs if a not in AOV_NAMES]
        if unknown:
            raise SceneError(f"unknown AOV {', '.join(map(repr, unknown))} "
                             f"(known: {', '.join(AOV_NAMES)})", where="--aov")
        targets = self._draw(scene, size)
        radiance = _read(targets["radiance"], "f4")
        display = _read(targets["display"], "f1")
        frame = Frame(radiance=radiance, display=display, camera=targets["camera"])
        if aovs:
            gb = targets["gbuffer"]
            channels = gb.read()
            for name in aovs:
                if name == "color" and "color" not in channels:
                    # meshes: the unlit colour is the albedo, premultiplied by coverage
                    channels["color"] = channels["albedo"] * channels["alpha"]
                frame.aovs[name] = channels[name]
        return frame

    def release(self) -> None:
        """Free every GPU resource (and the context, if this renderer created it)."""
        make_current(self.ctx)
        self._release()
        if self._owns_context:
            self.ctx.release()

    def _release(self) -> None:
        for ibl in self._ibl.values():
            ibl.release()
        for t in self._targets.values():
            t["gbuffer"].release()
            for k in ("radiance", "radiance_fbo", "display", "display_fbo"):
                t[k].release()
        for p in list(self._gbuffer_passes.values()) + list(self._shade_passes.values()):
            p.release()
        self._ibl.clear()
        self._targets.clear()
        self._gbuffer_passes.clear()
        self._shade_passes.clear()


def _read(texture, dtype: str) -> np.ndarray:
    w, h = texture.size
    np_dtype = np.float32 if dtype == "f4" else np.uint8
    arr = np.frombuffer(texture.read(), dtype=np_dtype).reshape(h, w, texture.components)
    return arr[::-1].copy()


def _load_object(obj: ObjectSpec):
    from .geometry import primitives

    if obj.type == "sphere":
        return [primitives.sphere(center=obj.center, radius=obj.radius, material=obj.material)]
    if obj.type == "plane":
        return [primitives.plane(center=obj.center, size=obj.size, normal=obj.normal,
                                 material=obj.material)]
    if obj.type == "material_grid":
        return primitives.material_ball_grid(rows=obj.rows, cols=obj.cols, spacing=obj.spacing,
                                             radius=obj.radius, albedo=obj.material.albedo,
                                             center=obj.center)
    if obj.type == "mesh":
        from .geometry.loaders import load_mesh

        transform = None if obj.transform is None else np.asarray(obj.transform, np.float64)
        return load_mesh(obj.path, transform=transform, material_override=obj.material)
    if obj.type == "gbuffer":
        from .geometry import imagespace

        path = Path(obj.path)
        if path.is_dir():
            return imagespace.load_ffhq_pbr(path)
        if path.suffix.lower() == ".exr":
            if obj.fov_y is None:
                return imagespace.load_stack_exr(path, fov_y=None, near=obj.near, far=obj.far)
            return imagespace.load_stack_exr(path, fov_y=obj.fov_y, near=obj.near, far=obj.far)
        raise InputError("an image-space G-buffer is a folder (FFHQ256-PBR layout) or a "
                         "12-channel .exr stack", where=path)
    raise SceneError(f"object type {obj.type!r} cannot be rendered")
