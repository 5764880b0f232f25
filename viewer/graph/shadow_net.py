"""The neural shadow estimator in the frame (``[render] shadow_net``): one pass, ``shadow_net``,
after the lighting (and the indirect light) and before transparent surfaces, that runs every layer
of the weights file (:class:`viewer.passes.shadow_net.ShadowNetPass`) on the unshadowed radiance,
the G-buffer and SSAO's occlusion, and multiplies its visibility into ``radiance`` in place (the
thesis's product form, eq. 4.3). Its feature maps are transient targets of the frame (given back
after the pass). Declared only when the setting names a file: no pass and no allocation
otherwise."""
from __future__ import annotations

from ..neural.format import WeightsError
from ..neural.shadow_net import load_shadow_net
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
                         "SSAO pass (ray-traced light replaces it): turn raytrace off",
                         where=path)
    size = tuple(int(s) for s in camera.size)
    maps = {name: g.create(f"shadow_net/{name}", TextureDesc(tiled, 4, "f4"))
            for name, tiled in map_sizes(net, size).items()}
    spass = renderer.resources.layout_pass("shadow_net", spec.layout)

    def estimate(f):
        spass.run(net, f["gbuffer"].textures, f["radiance"].texture, f[occlusion].texture,
                  {name: f[res].texture for name, res in maps.items()}, size)
    g.add_pass("shadow_net", estimate, reads=("gbuffer", "radiance", occlusion),
               writes=("radiance",) + tuple(maps.values()),
               inputs={"shadow_net": net.checkpoint})
