"""The frame graph (Filament's FrameGraph as the model): passes declare what they read and write,
the graph culls, reuses and allocates (:mod:`.graph`); render targets come from a bounded pool
(:mod:`.pool`) by descriptor (:mod:`.resources`); the renderer's own frame is declared in
:mod:`.frame`.

The shadow passes a frame declares: :mod:`.shadows`; the display chain (supersampling, tone
mapping): :mod:`.display`; the neural shadow estimator (``[render] shadow_net``, its visibility
multiplied into the radiance or in place of SSAO): :mod:`.shadow_net`.

Imports: :mod:`viewer.cache`, :mod:`viewer.errors`, :mod:`viewer.gbuffer`, :mod:`viewer.models`, :mod:`viewer.specialize`,
:mod:`viewer.scene`, :mod:`viewer.lighting`, :mod:`viewer.neural`, :mod:`viewer.passes`.
"""
from .graph import FrameGraph, FrameResources, PassNode, ResourceNode
from .pool import TargetPool
from .resources import GBufferDesc, Target, TextureDesc

__all__ = ["FrameGraph", "FrameResources", "GBufferDesc", "PassNode", "ResourceNode", "Target",
           "TargetPool", "TextureDesc"]
