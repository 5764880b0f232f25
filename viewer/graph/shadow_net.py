"""The neural shadow estimator in the frame (``[render] shadow_net``): after the lighting (and
the indirect light) and before transparent surfaces, one pass per layer of the weights file
(:class:`viewer.passes.shadow_net.ShadowNetPass`), ``shadow_net:<layer>``, each writing its
feature map ``shadow_net/<layer>`` (a transient target of the frame), then ``shadow_net``, which
multiplies the visibility into ``radiance`` in place (the thesis's product form, eq. 4.3). The layers read the
unshadowed radiance, the G-buffer and SSAO's occlusion. Per-layer passes let the graph skip the
whole chain when the radiance it produced is reused (a pass writing a transient is always drawn,
and an in-place writer of the radiance would then redraw the lighting every frame). Declared
only when the setting names a file: no pass and no allocation otherwise."""
from __future__ import annotations

from ..neural.format import WeightsError
from ..neural.shadow_net import SOURCE_FRAME, load_shadow_net
from ..passes.shadow_net import map_sizes
from .graph import FrameGraph
from .resources import TextureDesc


def shadow_net_passes(g: FrameGraph, renderer, scene, spec, camera, occlusion: str | None
                      ) -> None:
    """Declare ``shadow_net`` when ``scene.render.neural.shadow_net`` names a file;
    ``occlusion``: the frame's full-resolution SSAO resource (None: no SSAO pass ran)."""
    path = scene.render.neural.shadow_net
    if path is None:
        return
    net = load_shadow_net(path)
    if occlusion is None:
        raise WeightsError("the shadow estimator reads SSAO's occlusion, and this frame has no "
                           "SSAO pass (ray-traced light, on by default, replaces it): set "
                           "raytrace = false (--set raytrace=false)",
                           where=path)
    size = tuple(int(s) for s in camera.size)
    maps = {name: g.create(f"shadow_net/{name}", TextureDesc(tiled, 4, "f4"))
            for name, tiled in map_sizes(net, size).items()}
    spass = renderer.resources.layout_pass("shadow_net", spec.layout)
    for layer in net.layers:  # one pass per layer: transient maps, the product in place
        last = layer.name == net.layers[-1].name
        frame = SOURCE_FRAME in (layer.a_source, layer.b_source)
        reads = ((("gbuffer", "radiance", occlusion) if frame or last else ())
                 + tuple(maps[src] for src in (layer.a, layer.b) if src in maps))
        used = tuple(n for n in (layer.a, layer.b, layer.name) if n in maps)

        def run(f, only=(layer.name,), used=used):
            spass.run(net, f["gbuffer"].textures, f["radiance"].texture, f[occlusion].texture,
                      {name: f[maps[name]].texture for name in used}, size, only=only)
        g.add_pass("shadow_net" if last else f"shadow_net:{layer.name}", run, reads=reads,
                   writes=("radiance",) if last else (maps[layer.name],),
                   inputs={"shadow_net": net.checkpoint, "layer": layer.name})
