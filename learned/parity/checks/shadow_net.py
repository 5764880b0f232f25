"""The neural shadow estimator's passes (``passes/shadow_net_conv.comp``) against
:mod:`learned.twins.shadow_net`, on the parity scene's frame at an odd size (75 x 53: every level
has an odd side somewhere, so the replicated borders and the crops of the upsampling are
exercised) with seeded random weights of the default architecture with an output gain of 1.5
(``SN_GAIN``: V in (0, 1.5)) and the bilinear last decoder (``"upsample": "bilinear"``: dec1
reads bilinear, dec2-4 nearest, so both upsampling sources are checked layer by layer), reading
the radiance over the base colour (``"demodulate"``: ``SN_DEMODULATE`` in the first and last
layers, whose frame inputs the twin gets demodulated by :func:`frame_inputs`).

* ``shadow_net:layers`` - each layer alone: the twin of the layer on the maps GL left for its
  inputs, against the map GL wrote (the error of one layer, not the chain's).
* ``shadow_net`` - the whole network: the twin from the frame's inputs alone against GL's
  visibility, and the frame graph's product (``[render] shadow_net``) against the twin's product
  with the frame's unshadowed radiance (:func:`learned.twins.shadow_net.shadow_net_apply`).
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import torch
from safetensors.numpy import save_file

from learned.twins.shadow_net import (
    shadow_net,
    shadow_net_apply,
    shadow_net_conv,
    shadow_net_inputs,
)
from viewer.neural.shadow_net import (
    DEFAULT_ARCHITECTURE,
    demodulates,
    metadata,
    random_tensors,
    read_shadow_net,
    slices,
)
from viewer.passes.shadow_net import ShadowNetPass, map_sizes
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

from ..results import compare
from . import collector
from .models import PARITY_SCENE, gl_gbuffer, gl_texture

SIZE = (75, 53)
# float32 sums of up to 504 products per output (dec4) in another order than torch's conv2d:
# measured on llvmpipe max abs 6.0e-7 per layer (down1, on maps of magnitude ~1-10), 2.4e-7
# through the whole network on the output (1.5 x sigmoid, in (0, 1.5); 1.2e-7 with g = 1),
# 3.1e-5 (max rel 4.7e-7) on the product (radiance up to ~30 in the sky's sun reflections)
LAYER_ATOL, LAYER_RTOL = 2e-5, 1e-4
NET_ATOL, NET_RTOL = 2e-5, 1e-4
# the default layers with a gain, so that SN_GAIN is exercised (g = 1 is the default's identity)
PARITY_ARCHITECTURE = {**DEFAULT_ARCHITECTURE, "gain": 1.5, "upsample": "bilinear",
                       "demodulate": True}


def parity_weights(folder: Path, seed: int = 7) -> Path:
    """A weights file of :data:`PARITY_ARCHITECTURE` with seeded random tensors (scaled so the
    sigmoid output spans (0, 1) rather than saturating) written under ``folder``."""
    tensors = random_tensors(PARITY_ARCHITECTURE, seed=seed, scale=0.8)
    path = folder / "shadow_net_parity.safetensors"
    save_file(tensors, str(path), metadata=metadata(PARITY_ARCHITECTURE, tensors,
                                                    {"parity": True}))
    return path


def untile(arr: np.ndarray, channels: int) -> torch.Tensor:
    """A tiled map read back (``[H, W * S, 4]``) as ``[1, C, H, W]``."""
    h, ws, _ = arr.shape
    s = slices(channels)
    w = ws // s
    t = torch.from_numpy(arr.reshape(h, s, w, 4).transpose(1, 3, 0, 2).reshape(4 * s, h, w))
    return t[:channels][None]


def frame_inputs(renderer, scene, targets, demodulate: bool = False
                 ) -> tuple[torch.Tensor, ...]:
    """What the estimator reads in the frame ``targets`` that ``renderer`` drew for ``scene``
    without it (drawn with SSAO), in GL row order: ``radiance [1, 4, H, W]`` (unshadowed),
    ``inputs [1, 9, H, W]`` (the normals in view space, as the pass reads them; ``demodulate``:
    the radiance over the G-buffer's base colour), ``surface [1, 1, H, W]`` and ``ssao [H, W, 4]`` (r: the frame's
    O(x); g: S(x), which the frame's SSAO pass writes only when something reads it: here from
    :meth:`viewer.renderer.Renderer.environment_visibility`, the same pass on the same G-buffer,
    whose g the blur passes through unchanged)."""
    gb = gl_gbuffer(targets)

    def chw(t):
        return t.permute(2, 0, 1)[None]

    radiance = chw(torch.from_numpy(gl_texture(targets.radiance)))
    ssao = gl_texture(targets.ssao)
    ssao[..., 1] = gl_texture(renderer.environment_visibility(scene, targets))[..., 1]
    occ = chw(torch.from_numpy(ssao))
    # the pass reads view-space normals (u_view_rotation): the G-buffer's world normals rotated
    rot = torch.from_numpy(np.asarray(targets.camera.view_matrix()[:3, :3], np.float32))
    normal = torch.einsum("ij,hwj->hwi", rot, torch.as_tensor(gb["normal"]))
    inputs = shadow_net_inputs(radiance, occ[:, :1], chw(normal), chw(gb["depth"]),
                               occ[:, 1:2], chw(gb["albedo"]) if demodulate else None)
    surface = (gb["alpha"][..., 0] > 0.0) & (gb["depth"][..., 0] > 0.0)
    return radiance, inputs, surface[None, None], ssao


def run_gl_layers(programs, net, targets, ssao: np.ndarray) -> tuple[dict, np.ndarray]:
    """Every layer's map (read back, untiled) and the visibility GL computes on ``targets``
    with the occlusion and visibility ``ssao`` (``[H, W, 4]``, :func:`frame_inputs`)."""
    ctx = programs.ctx
    spass = ShadowNetPass(programs, targets.gbuffer.layout)
    sizes = map_sizes(net, SIZE)
    maps = {name: ctx.texture(size, 4, dtype="f4") for name, size in sizes.items()}
    vis = ctx.texture(SIZE, 4, dtype="f4")
    occ = ctx.texture(SIZE, 4, np.ascontiguousarray(ssao, np.float32).tobytes(), dtype="f4")
    try:
        spass.run(net, targets.gbuffer.textures, targets.radiance, occ, maps, SIZE,
                  visibility=vis, view_rotation=targets.camera.view_matrix())
        out = {layer.name: untile(gl_texture(maps[layer.name]), layer.out_channels)
               for layer in net.layers[:-1]}
        return out, gl_texture(vis)
    finally:
        for t in list(maps.values()) + [vis, occ]:
            t.release()
        spass.release()


def _scene(weights: Path | None):
    doc = {**PARITY_SCENE, "camera": {**PARITY_SCENE["camera"], "size": list(SIZE)}}
    scene = scene_from_dict(doc).with_render(model="ggx_split_sum", ssao=True, ssao_blur=False)
    return scene.with_render(shadow_net=str(weights)) if weights is not None else scene


def params_of(net) -> dict:
    return {layer.name: (torch.from_numpy(net.weight(layer.name)),
                         torch.from_numpy(net.bias(layer.name))) for layer in net.layers}


def checks() -> dict:
    """This module's pass checks: name -> (model or None, check(programs) -> results)."""
    found, register_pass_check = collector()

    @register_pass_check("shadow_net:layers", model="shadow_net")
    def check_layers(programs):
        with tempfile.TemporaryDirectory() as tmp:
            net = read_shadow_net(parity_weights(Path(tmp)))
        renderer = Renderer(ctx=programs.ctx)
        try:
            scene = _scene(None)
            targets = renderer.draw(scene)
            _, inputs, _, ssao = frame_inputs(renderer, scene, targets,
                                              demodulates(net.architecture))
            gl_maps, vis_gl = run_gl_layers(programs, net, targets, ssao)
        finally:
            renderer.release()
        maps = dict(gl_maps, input=inputs)
        params = params_of(net)
        results = []
        with torch.no_grad():
            for layer in net.layers:
                d = layer.as_dict()
                w, b = params[layer.name]
                ref = shadow_net_conv(maps[d["a"]], maps[d["b"]] if d["b"] else None, w, b, d)
                glsl = (gl_maps[layer.name] if layer.name != "out"
                        else torch.from_numpy(vis_gl).permute(2, 0, 1)[None, :3])
                results.append(compare(f"shadow_net:{layer.name}", glsl.numpy(), ref.numpy(),
                                       LAYER_ATOL, LAYER_RTOL, kind="pass",
                                       measured="max abs 6.0e-7 over the layers (seed 7)",
                                       envelope="float32 sums of <= 504 products in another "
                                                "order; exp of the sigmoid 3 + 2|x| ulp"))
        return results

    @register_pass_check("shadow_net", model="shadow_net")
    def check_network(programs):
        with tempfile.TemporaryDirectory() as tmp:
            path = parity_weights(Path(tmp))
            net = read_shadow_net(path)
            renderer = Renderer(ctx=programs.ctx)
            try:
                scene = _scene(None)
                plain = renderer.draw(scene)
                radiance, inputs, surface, ssao = frame_inputs(
                    renderer, scene, plain, demodulates(net.architecture))
                _, vis_gl = run_gl_layers(programs, net, plain, ssao)
                shaded_gl = gl_texture(renderer.draw(_scene(path)).radiance)
            finally:
                renderer.release()
        layers = [layer.as_dict() for layer in net.layers]
        with torch.no_grad():
            vis = shadow_net(inputs, layers, params_of(net))
            shaded = shadow_net_apply(radiance, vis, surface)
        chw_vis = np.ascontiguousarray(vis[0].permute(1, 2, 0).numpy())
        return [compare("shadow_net:network", vis_gl[..., :3], chw_vis, NET_ATOL, NET_RTOL,
                        kind="pass", measured="max abs 2.4e-7 (seed 7, 75 x 53, g 1.5)",
                        envelope="the layers' envelopes through 15 layers; 1.5 x sigmoid"),
                compare("shadow_net:frame", shaded_gl,
                        np.ascontiguousarray(shaded[0].permute(1, 2, 0).numpy()), NET_ATOL,
                        NET_RTOL, kind="pass", measured="max abs 3.1e-5, max rel 4.7e-7",
                        envelope="the network's, times the radiance")]

    return found
