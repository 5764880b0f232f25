"""The neural shadow estimator (thesis sec. 4.3.2, eq. 4.3):

    I_shadow = f_eta(I_unshadow, I_normal, I_ssao)        a small UNet
    I_rgb    = I_unshadow (.) I_shadow                     Hadamard product

Input channels: the unshadowed render (3, log-compressed: log(1 + x)), the normal map (3) and the
occlusion map (1); output: a per-pixel, per-channel shadow map in [0, 1] (sigmoid). Trained in phase
2 with the shader frozen (L1 over all pixels, eq. 4.6). Two down/up levels with skip connections;
any image size works (odd sizes are padded and cropped).

This UNet is the thesis's, for the torch two-stage teacher (``relight train``'s phase 2); the
estimator the viewer runs in GLSL, redesigned for real time (5 levels, the first operation at half
resolution, depth among its inputs), is :mod:`learned.neural.shadow_net`.
"""
from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F


def _block(cin: int, cout: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, padding=1), nn.ReLU(inplace=True),
                         nn.Conv2d(cout, cout, 3, padding=1), nn.ReLU(inplace=True))


class ShadowUNet(nn.Module):
    kind = "shadow"

    def __init__(self, width: int = 16):
        super().__init__()
        self.width = int(width)
        w = self.width
        self.enc0 = _block(7, w)
        self.enc1 = _block(w, 2 * w)
        self.mid = _block(2 * w, 4 * w)
        self.dec1 = _block(4 * w + 2 * w, 2 * w)
        self.dec0 = _block(2 * w + w, w)
        self.out = nn.Conv2d(w, 3, 1)
        nn.init.zeros_(self.out.weight)
        nn.init.constant_(self.out.bias, 4.0)  # start near "no shadow" (sigmoid(4) = 0.98)

    @property
    def config(self) -> dict:
        return {"width": self.width}

    def shadow_map(self, unshadowed: torch.Tensor, normal: torch.Tensor, ao: torch.Tensor
                   ) -> torch.Tensor:
        """``[B, 3, H, W]``, ``[B, 3, H, W]``, ``[B, 1, H, W]`` -> shadow map ``[B, 3, H, W]``."""
        x = torch.cat([torch.log(1.0 + unshadowed.clamp_min(0.0)), normal, ao], dim=1)
        h, w = x.shape[-2:]
        ph, pw = (-h) % 4, (-w) % 4
        x = F.pad(x, (0, pw, 0, ph), mode="replicate")
        e0 = self.enc0(x)
        e1 = self.enc1(F.max_pool2d(e0, 2))
        m = self.mid(F.max_pool2d(e1, 2))
        d1 = self.dec1(torch.cat([F.interpolate(m, scale_factor=2.0), e1], 1))
        d0 = self.dec0(torch.cat([F.interpolate(d1, scale_factor=2.0), e0], 1))
        return torch.sigmoid(self.out(d0))[..., :h, :w]

    def forward(self, unshadowed, normal, ao):
        return unshadowed * self.shadow_map(unshadowed, normal, ao)


def load_shadow(path) -> ShadowUNet:
    """The UNet of a state dict saved by ``relight train`` (``RUN/shadow_final.pt``; the UNet is
    not exported to the viewer), its width read from the first convolution."""
    state = torch.load(path, map_location="cpu", weights_only=True)
    model = ShadowUNet(width=int(state["enc0.0.weight"].shape[0]))
    model.load_state_dict(state)
    return model.eval()
