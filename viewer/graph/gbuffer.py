"""The G-buffer's passes: a lone image stack's own textures (imported), else meshes and image
stacks rasterised (``gbuffer``) and splats composited over them (``splats``).

An image stack with shadow-only proxies (meshes that cast into the shadow maps and rays but are
not seen) has its depth snapped to theirs first, where the two lie within ``[render]
shadow_proxy_snap`` of the proxies' depth (:mod:`viewer.geometry.proxy_snap`): an estimated
depth a little behind a proxy's surface would otherwise be shadowed by that surface.
"""
from __future__ import annotations

from ..models import refracts_forward
from ..passes.gbuffer import GBufferTargets
from ..scene.camera import Camera
from ..scene.description import Scene
from ..specialize import Specialization
from .graph import FrameGraph
from .resources import GBufferDesc


def gbuffer_passes(g: FrameGraph, renderer, scene: Scene, spec: Specialization,
                   camera: Camera) -> None:
    """Declare the G-buffer's passes of ``scene`` seen through ``camera`` (module docstring)."""
    res = renderer.resources
    gpass = res.layout_pass("gbuffer", spec.layout)
    identity = {"objects": scene.objects, "camera": camera, "layout": spec.layout,
                "geometry": renderer.geometry_cache.version}
    if spec.direct_stack:
        # one image-space stack and nothing else: its uploaded textures already are a G-buffer in
        # this layout, so the lighting pass reads them and no copy pass runs
        stack = renderer.geometry(scene.objects[0])
        view = GBufferTargets(ctx=renderer.ctx, layout=spec.layout, size=tuple(camera.size),
                              textures=dict(gpass._stack_textures(stack)), depth=None, fbo=None)
        g.import_resource("gbuffer", view, signature=tuple(sorted(identity.items())))
        return
    g.create("gbuffer", GBufferDesc(spec.layout, tuple(camera.size)), kept=True)
    contents = [(obj, renderer.geometry(obj)) for obj in scene.objects]
    clouds = [c for obj, c in contents if obj.type == "splats" and not obj.shadow_only]
    # KHR_materials_transmission surfaces the forward pass refracts are not in the G-buffer
    through = refracts_forward(scene.render.model) and any(
        m.material.transmission > 0.0 for obj, c in contents
        if obj.type not in ("gbuffer", "splats") and not obj.shadow_only for m in c)
    if through:
        identity["forward_transmission"] = True
    # the shadow-only proxies an image stack's depth snaps to (none: nothing snaps)
    proxies = tuple(m for obj, c in contents if obj.shadow_only
                    and obj.type not in ("gbuffer", "splats") for m in c)
    snap = scene.render.shadow.proxy_snap if proxies else 0.0
    if snap > 0.0 and any(obj.type == "gbuffer" for obj, _ in contents):
        identity["proxy_snap"] = snap

    def gbuffer(f):
        gb = f["gbuffer"]
        # snapped before anything is drawn: the proxies' depth is drawn into gb and cleared
        images = {id(c): gpass.snapped_stack(gb, c, camera, proxies, snap) if snap > 0.0 else c
                  for obj, c in contents if obj.type == "gbuffer"}
        gb.clear()
        meshes = []
        for obj, content in contents:
            if obj.type == "gbuffer":
                gpass.draw_image(gb, images[id(content)])
            elif obj.type != "splats" and not obj.shadow_only:  # a caster only: maps, rays
                meshes.extend(m for m in content if m.alpha_mode != "BLEND"  # BLEND, refracted:
                              and not (through and m.material.transmission > 0.0))  # forward
        if meshes:
            gpass.draw_meshes(gb, camera, meshes)
    g.add_pass("gbuffer", gbuffer, writes=("gbuffer",), inputs=identity)
    if clouds:  # after meshes: depth-tested against them, composited over them

        def splats(f):
            res.layout_pass("splats", spec.layout).draw_clouds(
                f["gbuffer"], camera, clouds, depth=scene.render.splat_depth)
        g.add_pass("splats", splats, reads=("gbuffer",), writes=("gbuffer",),
                   inputs={**identity, "splat_depth": scene.render.splat_depth})
