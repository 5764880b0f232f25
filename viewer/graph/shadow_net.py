"""The neural shadow estimator in the frame (``[render] shadow_net``), one pass per layer of the
weights file (:class:`viewer.passes.shadow_net.ShadowNetPass`), ``shadow_net:<layer>``, each
writing its feature map ``shadow_net/<layer>`` (a transient target of the frame). Per-layer
passes let the graph skip the whole chain when the radiance it led to is reused (a pass writing
a transient is always drawn, and an in-place writer of the radiance would then redraw the
lighting every frame). Declared only when the setting names a file: no pass and no allocation
otherwise. ``[render] shadow_net_use`` says where the visibility V goes:

* ``"product"`` (the default; every model): after the lighting (and the indirect light) and
  before transparent surfaces, the last layer, ``shadow_net``, multiplies V into ``radiance`` in
  place (the thesis's product form, eq. 4.3); the layers read that unshadowed radiance.
* ``"visibility"`` (:data:`VISIBILITY_MODELS`): V takes the place of SSAO's occlusion O(x) and a
  student's S(x) in the lighting pass. The estimator still reads an unshadowed render, so the
  frame draws the lighting twice: ``shadow_net:shade`` with SSAO into ``shadow_net/radiance``
  (transient), the layers on it, the last writing V to ``shadow_net/visibility``, and ``shade``
  reading that map where it would read SSAO's (``SSAO_SHADOW_NET``: ``passes/deferred.glsl``
  takes the mean of V's colours for both, as they are one number each)."""
from __future__ import annotations

import warnings

from ..errors import SceneError
from ..neural.format import WeightsError
from ..neural.shadow_net import SOURCE_FRAME, frame_settings, load_shadow_net
from ..passes.shadow_net import map_sizes
from .graph import FrameGraph
from .resources import TextureDesc

# the rasterised models whose lighting pass reads SSAO's occlusion (and the student its S(x))
# without accumulating Monte-Carlo samples: the ones V can stand in for
VISIBILITY_MODELS = ("blinn_phong", "ggx_split_sum", "neural")
VISIBILITY = "shadow_net/visibility"
RADIANCE = "shadow_net/radiance"


def visibility_route(settings) -> bool:
    """Whether the frame takes the estimator's visibility in place of SSAO (``shadow_net`` set,
    ``shadow_net_use = "visibility"``); a model it cannot stand in for is one line."""
    if settings.neural.shadow_net is None or settings.neural.shadow_net_use != "visibility":
        return False
    if settings.model not in VISIBILITY_MODELS:
        raise SceneError(f'render.shadow_net_use = "visibility" replaces the SSAO that '
                         f'{", ".join(VISIBILITY_MODELS)} read; model {settings.model!r} does '
                         f'not read it: use shadow_net_use = "product"')
    return True


# the frame's settings an estimator file records (frame_settings) and checks: key -> (what it
# is, the settings' value)
FRAME_CHECKS = {
    "indirect": ("the indirect light", lambda s: bool(s.ssao.indirect)),
    "specular_occlusion": ("specular occlusion", lambda s: bool(s.specular_occlusion)),
}


def check_frame(net, settings) -> None:
    """Warn (one line naming the file) when the frame is not the one the estimator was trained
    to multiply (:func:`viewer.neural.shadow_net.frame_settings`; files without the record: no
    indirect light, no specular occlusion) against ``[render] indirect`` and
    ``specular_occlusion``. V then corrects light the frame has not got (or lacks the light it
    has)."""
    frame = frame_settings(net.training)
    wrong = {k: bool(frame[k]) for k, (_, now) in FRAME_CHECKS.items()
             if bool(frame[k]) != now(settings)}
    if wrong:
        had = " and ".join(f"{'with' if v else 'without'} {FRAME_CHECKS[k][0]}"
                           for k, v in wrong.items())
        fix = " ".join(f"{k} = {str(v).lower()}" for k, v in wrong.items())
        warnings.warn(f"{net.path}: the shadow estimator was trained on frames {had}, which "
                      f"this frame differs from: set {fix} for the image it was scored on",
                      stacklevel=2)


def shadow_net_passes(g: FrameGraph, renderer, scene, spec, camera, occlusion: str | None,
                      radiance: str = "radiance", visibility: str | None = None) -> None:
    """Declare the estimator when ``scene.render.neural.shadow_net`` names a file: its layers
    read ``radiance`` (the unshadowed render), the G-buffer and ``occlusion`` (the frame's
    full-resolution SSAO resource; None: no SSAO pass ran); the last multiplies V into
    ``radiance`` in place, or, given ``visibility`` (a resource this creates, transient), writes
    V there."""
    path = scene.render.neural.shadow_net
    if path is None:
        return
    net = load_shadow_net(path)
    check_frame(net, scene.render)
    if occlusion is None:
        raise WeightsError("the shadow estimator reads SSAO's occlusion, and this frame has no "
                           "SSAO pass (ray-traced light, on by default, replaces it): set "
                           "raytrace = false (--set raytrace=false)",
                           where=path)
    size = tuple(int(s) for s in camera.size)
    rotation = camera.view_matrix()[:3, :3]  # the estimator reads view-space normals
    maps = {name: g.create(f"shadow_net/{name}", TextureDesc(tiled, 4, "f4"))
            for name, tiled in map_sizes(net, size).items()}
    if visibility is not None:
        g.create(visibility, TextureDesc(size, 4, "f4"))
    spass = renderer.resources.layout_pass("shadow_net", spec.layout)
    for layer in net.layers:  # one pass per layer: transient maps, the product in place
        last = layer.name == net.layers[-1].name
        frame = SOURCE_FRAME in (layer.a_source, layer.b_source)
        reads = ((("gbuffer", radiance, occlusion) if frame or last else ())
                 + tuple(maps[src] for src in (layer.a, layer.b) if src in maps))
        used = tuple(n for n in (layer.a, layer.b, layer.name) if n in maps)

        def run(f, only=(layer.name,), used=used, last=last):
            spass.run(net, f["gbuffer"].textures, f[radiance].texture, f[occlusion].texture,
                      {name: f[maps[name]].texture for name in used}, size, only=only,
                      visibility=f[visibility].texture if last and visibility else None,
                      view_rotation=rotation)
        out = (visibility or radiance) if last else maps[layer.name]
        name = (f"shadow_net:{layer.name}" if not last else
                "shadow_net" if visibility is None else "shadow_net:visibility")
        g.add_pass(name, run, reads=reads, writes=(out,),
                   inputs={"shadow_net": net.checkpoint, "layer": layer.name})
