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

``light_input=False`` (architecture ``"light_input": false``) drops the log(1 + L_in) feature:
rho then depends on the material, n, l, v and h only, a BRDF times the cosine, so L_o is exactly
linear in the light by construction. With the feature, rho can depend on the light's intensity
and colour: trained under the HDR suns of path-traced data, such a teacher failed the white
furnace (blue 0.59 for 0.8) and rendered twice the light as 2.5-2.9 times the radiance.
"""
from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

from .encoding import encoded_size, fourier_encode
from .lighting import Lighting, env_radiance, sample_lights, surface
from learned.twins.common import half_vector  # GLSL lib/common.glsl (same function)

from viewer.neural.contract import teacher_inputs

INPUTS = teacher_inputs(True)  # the thesis's inputs, with log(1 + L_in)


class Teacher(nn.Module):
    kind = "teacher"

    def __init__(self, hidden: int = 64, num_freqs: int = 4, light_input: bool = True):
        super().__init__()
        self.hidden_size = int(hidden)
        self.num_freqs = int(num_freqs)
        self.light_input = bool(light_input)  # log(1 + L_in) among the inputs (module doc)
        self.inputs = teacher_inputs(self.light_input)
        h = self.hidden_size
        self.diffuse = nn.ModuleList([nn.Linear(encoded_size(len(self.inputs), self.num_freqs),
                                                h),
                                      nn.Linear(h, h)])
        self.specular = nn.ModuleList([nn.Linear(h + 6, h), nn.Linear(h, 3)])

    @property
    def config(self) -> dict:
        cfg = {"hidden": self.hidden_size, "num_freqs": self.num_freqs}
        if not self.light_input:  # files of teachers with the input stay as they were
            cfg["light_input"] = False
        return cfg

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
        parts = [mat[..., :3], n, mat[..., 3:6], l, nol]
        if self.light_input:
            parts.append(torch.log(1.0 + lin))
        raw = torch.cat(parts, dim=-1)
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
