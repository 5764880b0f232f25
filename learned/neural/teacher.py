"""The physics-based neural deferred shader (PBND, thesis sec. 4.3.2, eq. 4.2; fig. 4.5).

Per pixel and per sampled light direction l:

    x      = enc(albedo, n, roughness, metallic, specular, l, n.l, log(1 + L_in))   Fourier features
    feat   = DiffuseMLP(x)            2 fully connected layers, ReLU; no view input (isotropic)
    rho    = softplus(SpecularMLP([feat, v, h]))    2 layers; h = normalize(v + l)
    c(l)   = rho * L_in / p(l),        L_in = L_i(l) <n.l>_+

    L_o    = 1/N sum_i c(l_i)         (averaged over N sampled directions)

The thesis feeds L_i(l)<n.l> as an input feature; we feed it too (log-compressed, HDR) and also
multiply it out, so the network's RGB output is a learned reflectance and the average is an
unbiased Monte-Carlo estimate for any pdf: uniform hemisphere, cosine, or environment importance
sampling (thesis Table 5.2, appendix B.4) train and evaluate the same network.
"""
from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

from .encoding import encoded_size, fourier_encode
from .lighting import Lighting, env_radiance, sample_lights, surface
from learned.twins.common import half_vector  # GLSL lib/common.glsl (same function)

INPUTS = ("albedo.r", "albedo.g", "albedo.b", "n.x", "n.y", "n.z", "roughness", "metallic",
          "specular", "l.x", "l.y", "l.z", "NoL", "log_Lin.r", "log_Lin.g", "log_Lin.b")


class Teacher(nn.Module):
    kind = "teacher"

    def __init__(self, hidden: int = 64, num_freqs: int = 4):
        super().__init__()
        self.hidden_size = int(hidden)
        self.num_freqs = int(num_freqs)
        h = self.hidden_size
        self.diffuse = nn.ModuleList([nn.Linear(encoded_size(len(INPUTS), self.num_freqs), h),
                                      nn.Linear(h, h)])
        self.specular = nn.ModuleList([nn.Linear(h + 6, h), nn.Linear(h, 3)])

    @property
    def config(self) -> dict:
        return {"hidden": self.hidden_size, "num_freqs": self.num_freqs}

    def networks(self) -> dict[str, list[tuple[torch.Tensor, torch.Tensor, str]]]:
        d, s = self.diffuse, self.specular
        return {"diffuse": [(d[0].weight, d[0].bias, "relu"), (d[1].weight, d[1].bias, "relu")],
                "specular": [(s[0].weight, s[0].bias, "relu"), (s[1].weight, s[1].bias, "softplus")]}

    def macs_per_sample(self) -> int:
        return sum(l.in_features * l.out_features for l in (*self.diffuse, *self.specular))

    def parameter_count(self) -> int:
        return sum(p.numel() for p in self.parameters())

    def contribution(self, mat: torch.Tensor, n: torch.Tensor, v: torch.Tensor, l: torch.Tensor,
                     li: torch.Tensor) -> torch.Tensor:
        """rho * L_in for ``mat [..., 6]`` (albedo, roughness, metallic, specular), shading normal
        ``n``, view ``v``, light ``l`` (``[..., 3]`` each) and radiance ``li [..., 3]``."""
        nol = (n * l).sum(-1, keepdim=True)
        lin = li * nol.clamp_min(0.0)
        raw = torch.cat([mat[..., :3], n, mat[..., 3:6], l, nol, torch.log(1.0 + lin)], dim=-1)
        h = fourier_encode(raw, self.num_freqs)
        for layer in self.diffuse:
            h = torch.relu(layer(h))
        h = torch.cat([h, v, half_vector(v, l)], dim=-1)
        h = torch.relu(self.specular[0](h))
        rho = F.softplus(self.specular[1](h))
        return rho * lin

    def forward(self, gb: dict, v: torch.Tensor, lighting: Lighting, u: torch.Tensor,
                strategy: str = "env") -> torch.Tensor:
        """Radiance ``[N, 3]``: the mean over ``u [N, S, 2]`` light samples (uniform pairs)."""
        n, _ = surface(gb, v)
        l, pdf = sample_lights(n[:, None, :], u, strategy, lighting)  # [N, S, 3], [N, S]
        li = env_radiance(lighting, l)
        s = u.shape[1]
        mat = torch.cat([gb["albedo"], gb["roughness"], gb["metallic"], gb["specular"]], dim=-1)
        c = self.contribution(mat[:, None, :].expand(-1, s, -1), n[:, None, :].expand(-1, s, -1),
                              v[:, None, :].expand(-1, s, -1), l, li)
        ok = pdf > 0.0
        w = torch.where(ok, 1.0 / torch.where(ok, pdf, torch.ones_like(pdf)), torch.zeros_like(pdf))
        return (c * w[..., None]).mean(1)
