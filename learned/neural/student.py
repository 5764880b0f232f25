"""The distilled student: one small MLP evaluation per pixel from pre-integrated lighting.

Design (chosen by measurement among :data:`DESIGNS`, see README "Neural shader" and
:func:`relight.bench.students.compare_students`): the teacher integrates N light samples per pixel; the
student instead reads the two pre-integrated lighting terms every classical model already has -
SH irradiance E(n) and the GGX-prefiltered radiance P(r, roughness) - and an MLP of the per-pixel
material and n.v predicts how much of each the surface reflects. Two output forms
(:data:`OUTPUTS`; the weights file records which, ``lib/neural.glsl`` holds both)::

    x = enc(albedo, roughness, metallic, specular, ao, n.v [, dfg.a, dfg.b])
    free6: k = sigmoid(MLP(x)) [6]    L_o = S k_d * albedo * E / pi + S k_s * P      (per channel)
    pbr3:  k = sigmoid(MLP(x)) [3]    L_o = S k_d diffuse * E / pi + S (k_a f0 + k_b f90) P
    split3: k = sigmoid(MLP(x)) [3]   L_o = S k_d diffuse E / pi (1 - e_spec)
                                            + S (k_a f0 (dfg.y - dfg.x) + k_b f90 dfg.x) P
            (P along the dominant direction: k = 0.5 is ggx_split_sum, where it starts)
            sun=True: the base is ggx_split_sum with SUN_LIGHT: E and P without the
            environment's sun (P mixed with the whole environment's chain where the lobe is
            narrower than the sun) + the sun as a light with the same k
            (neural_student_sun_split; k = 0.5: ggx_environment_sun)
            multiscatter=True: the specular terms times ggx_split_sum's multiple-scattering
            compensation m = 1 + f0 (1/dfg.y - 1) and e_spec m in the diffuse's (1 - e_spec m):
            k = 0.5 is ggx_split_sum with multiscatter, the classical model's default

    occlusion "factor" (:data:`OCCLUSIONS`): k_d = ao sigmoid(...), AO applied outside the MLP
    indirect "factor" (:data:`INDIRECTS`): k_i = sigmoid(MLP_i(x)), a second network of
            :data:`INDIRECT_HIDDEN` relu units on the same inputs, L = L_o + S k_i L_ind with
            L_ind the screen-space one-bounce light of passes/ssao.frag (k_i = 0.5: the
            classical indirect term, where it starts)

with S = :data:`OUTPUT_SCALE` = 2 (room for the indirect light the teacher learned), diffuse =
``diffuse_color(albedo, metallic)``, f0 = ``compute_f0(albedo, metallic, specular)`` and f90 =
``f90_from_f0(f0)``. Both are exactly linear in the environment (any intensity, any HDR range)
and cost one evaluation per pixel. ``free6`` predicts six free per-channel factors, so nothing
ties the colour of the result to the material: an imperfectly trained network tints a grey floor
purple or green. ``pbr3`` is the split-sum form (Karis 2013; Filament: f0 (dfg.y - dfg.x) + f90
dfg.x) with learned achromatic scale and bias: the colour comes from the material and the
lighting alone, and the network learns shadowing, AO, indirect light and Fresnel corrections.
With ``features="dfg"`` the two split-sum terms of the DFG LUT at (n.v, roughness) are inputs
too: the classical specular factor is then one linear map away.
"""
from __future__ import annotations

import torch
from torch import nn

from learned.twins.brdf import clamp_perceptual_roughness, compute_f0, f90_from_f0
from learned.twins.ibl import ibl_energy_compensation
from learned.twins.neural import (NEURAL_OUTPUT_SCALE, neural_indirect_factor,
                                  neural_student_radiance, neural_student_radiance_pbr,
                                  neural_student_radiance_split, neural_student_sun_split)
from learned.twins.shading import diffuse_color
from viewer.neural.contract import STUDENT_SSAO_FEATURES

from .encoding import encoded_size, fourier_encode

# input sets (feature name -> inputs); the generated GLSL and viewer/neural/ share these
INPUTS = ("albedo.r", "albedo.g", "albedo.b", "roughness", "metallic", "specular", "ao", "NoV")
# every input in the order :func:`learned.neural.lighting.student_features` returns them (twin:
# viewer.neural.STUDENT_ALL_INPUTS); "vis": the screen-space visibility of the environment's light
# "env_below": the environment's irradiance from below over that from above (one value a frame,
# learned.neural.torch_lighting.env_below)
ALL_INPUTS = INPUTS + ("dfg.a", "dfg.b", "vis", "env_below")
# "ssao": the network reads neither ao nor S(x); ao (material AO x the SSAO pass's O(x)) is only
# the occlusion factor, applied as the classical models apply it (issue 38: the students that
# read screen-space evidence turned its noise and stretch into speckle and invented shadows)
FEATURE_INPUTS = {"base": INPUTS, "dfg": INPUTS + ("dfg.a", "dfg.b"),
                  "ssao": tuple(i for i in INPUTS if i != "ao"),
                  "ssao-env": tuple(i for i in INPUTS if i != "ao") + ("env_below",),
                  "vis": INPUTS + ("vis",), "dfg-vis": INPUTS + ("dfg.a", "dfg.b", "vis")}
OUTPUT_SCALE = NEURAL_OUTPUT_SCALE
# output forms (architecture "output"; twin: viewer.neural.STUDENT_OUTPUTS) -> network outputs
OUTPUTS = {"free6": 6, "pbr3": 3, "split3": 3}
# how the ao input enters (architecture "occlusion"; twin:
# viewer.neural.contract.STUDENT_OCCLUSION):
# "factor" (new students) multiplies the diffuse factor(s) by ao outside the MLP, as every classical
# model applies AO; "input" (files written before) leaves the product to the MLP, which learned the
# training set's mean occlusion as a constant instead (issue 14: white furnace 0.42 for 0.8)
OCCLUSIONS = ("input", "factor")
# whether the student learns a factor on the screen-space indirect light (architecture "indirect";
# twin: viewer.neural.contract.STUDENT_INDIRECT): "factor" = a second network "indirect" of
# INDIRECT_HIDDEN relu units on the same inputs, one sigmoid output
INDIRECTS = ("none", "factor")
INDIRECT_HIDDEN = 16  # twin: viewer.neural.contract.INDIRECT_HIDDEN

# Candidate designs of the measured comparison (relight.bench.students.compare_students):
# name -> Student keyword arguments
DESIGNS: dict[str, dict] = {
    "w16": {"hidden": (16,)},
    "w16x2": {"hidden": (16, 16)},
    "w32x2": {"hidden": (32, 32)},
    "w64x2": {"hidden": (64, 64)},
    "w32x2-pe2": {"hidden": (32, 32), "num_freqs": 2},
    "w16x2-dfg": {"hidden": (16, 16), "features": "dfg"},
    "w32x2-dfg": {"hidden": (32, 32), "features": "dfg"},
    "w16-pbr": {"hidden": (16,), "output": "pbr3"},
    "w16x2-pbr": {"hidden": (16, 16), "output": "pbr3"},
    "w16x2-dfg-pbr": {"hidden": (16, 16), "features": "dfg", "output": "pbr3"},
    "w32x2-dfg-pbr": {"hidden": (32, 32), "features": "dfg", "output": "pbr3"},
    # students that see visibility (issue 14, part 3): + S(x) of the SSAO pass, ao = AO x SSAO;
    # split3: corrections of the split-sum model (k = 0.5 is ggx_split_sum)
    "w16x2-vis-pbr": {"hidden": (16, 16), "features": "vis", "output": "pbr3"},
    "w32x2-vis-pbr": {"hidden": (32, 32), "features": "vis", "output": "pbr3"},
    "w16x2-split": {"hidden": (16, 16), "output": "split3"},
    "w16x2-vis-split": {"hidden": (16, 16), "features": "vis", "output": "split3"},
    "w32x2-vis-split": {"hidden": (32, 32), "features": "vis", "output": "split3"},
}
# the comparison's candidate its table marks as shipped; the shipped student itself is a later
# design (learned.train.config.SHIPPED_STUDENT: w32x2-vis-split with the sun light, multiple
# scattering and a learned indirect factor, trained on path-traced truth)
SHIPPED_DESIGN = "w16x2-pbr"


class Student(nn.Module):
    kind = "student"

    def __init__(self, hidden: tuple[int, ...] = (32, 32), num_freqs: int = 0,
                 features: str = "base", output: str = "free6", occlusion: str = "factor",
                 indirect: str = "none", sun: bool = False, multiscatter: bool = False):
        super().__init__()
        if features not in FEATURE_INPUTS:
            raise ValueError(f"unknown student features {features!r} "
                             f"(known: {', '.join(FEATURE_INPUTS)})")
        if output not in OUTPUTS:
            raise ValueError(f"unknown student output form {output!r} "
                             f"(known: {', '.join(OUTPUTS)})")
        if occlusion not in OCCLUSIONS:
            raise ValueError(f"unknown student occlusion {occlusion!r} "
                             f"(known: {', '.join(OCCLUSIONS)})")
        if indirect not in INDIRECTS:
            raise ValueError(f"unknown student indirect {indirect!r} "
                             f"(known: {', '.join(INDIRECTS)})")
        if indirect != "none" and OUTPUTS[output] != 3:
            raise ValueError(f"student indirect {indirect!r} needs a three-factor output form "
                             f"(pbr3 or split3), not {output!r}")
        if features in ("ssao", "ssao-env") and occlusion != "factor":
            raise ValueError("a student with ssao features applies ao only as a factor: "
                             f"occlusion must be 'factor', not {occlusion!r}")
        if sun and output != "split3":
            raise ValueError(f"a student with the sun needs the split3 output form, not {output!r}")
        if multiscatter and output != "split3":
            raise ValueError("a student with multiscatter needs the split3 output form, "
                             f"not {output!r}")
        self.multiscatter = bool(multiscatter)
        self.occlusion = occlusion
        self.indirect = indirect
        self.sun = bool(sun)
        self.hidden = tuple(int(h) for h in hidden)
        self.num_freqs = int(num_freqs)
        self.features = features
        self.output = output
        n_in = encoded_size(len(self.inputs), self.num_freqs)
        sizes = [n_in, *self.hidden, OUTPUTS[output]]
        self.layers = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))
        # the factor on the indirect light: a second network (empty without one)
        self.indirect_layers = nn.ModuleList(
            [nn.Linear(n_in, INDIRECT_HIDDEN), nn.Linear(INDIRECT_HIDDEN, 1)]
            if indirect != "none" else [])
        # start at the classical model: k = sigmoid(0) = 0.5 everywhere (split3: ggx_split_sum;
        # the indirect factor: S k = 1, the classical one-bounce term)
        for last in ([self.layers[-1]] if output == "split3" else []) + list(
                self.indirect_layers[-1:]):
            nn.init.zeros_(last.weight)
            nn.init.zeros_(last.bias)

    @property
    def inputs(self) -> tuple[str, ...]:
        return FEATURE_INPUTS[self.features]

    @property
    def config(self) -> dict:
        return {"hidden": list(self.hidden), "num_freqs": self.num_freqs,
                "features": self.features, "output": self.output, "occlusion": self.occlusion,
                "indirect": self.indirect, "sun": self.sun, "multiscatter": self.multiscatter}

    def activations(self) -> list[str]:
        return ["relu"] * len(self.hidden) + ["sigmoid"]

    @property
    def reads_visibility(self) -> bool:
        """Whether it reads S(x), the SSAO pass's visibility of the environment's light."""
        return "vis" in self.inputs

    @property
    def reads_occlusion(self) -> bool:
        """Whether its ao input is the material AO times the SSAO pass's O(x)."""
        return self.features in STUDENT_SSAO_FEATURES

    @property
    def learns_indirect(self) -> bool:
        """Whether it learns a factor on the screen-space indirect light (a second network)."""
        return self.indirect != "none"

    @property
    def dominant(self) -> bool:
        """Whether its prefiltered input is read along the dominant direction (``split3``)."""
        return self.output == "split3"

    def select(self, x: torch.Tensor) -> torch.Tensor:
        """This student's inputs of ``x [N, k]`` in :data:`ALL_INPUTS` order (``k`` >= the last
        input it reads: ``[N, 8]`` serves a base student)."""
        cols = [ALL_INPUTS.index(name) for name in self.inputs]
        if cols == list(range(len(cols))):
            return x[:, :len(cols)]
        return x[:, cols]

    def network_outputs(self, x: torch.Tensor) -> torch.Tensor:
        """The networks' sigmoid outputs ``[N, 6 | 3 | 4]`` for ``x`` (:meth:`weights` before the
        ao input multiplies the diffuse factor): S k is each correction, 1 where k = 0.5."""
        x_enc = fourier_encode(self.select(x), self.num_freqs)
        h = x_enc
        for layer in self.layers[:-1]:
            h = torch.relu(layer(h))
        k = torch.sigmoid(self.layers[-1](h))
        if self.learns_indirect:
            k_i = torch.sigmoid(self.indirect_layers[1](torch.relu(self.indirect_layers[0](x_enc))))
            k = torch.cat([k, k_i], dim=-1)
        return k

    def gain(self, outputs: torch.Tensor) -> torch.Tensor:
        """How far the direct-light corrections of :meth:`network_outputs` ``outputs`` brighten
        the base: the mean over pixels of the sum over the corrections of max(S k - 1, 0)
        (:data:`OUTPUT_SCALE` S; the indirect factor excluded), 0 for a student that only darkens
        its split-sum base. The penalty of ``TrainConfig.student_gain_penalty``: the base's
        direct light can be occluded, and the light it misses from nearby surfaces is what the
        indirect term carries."""
        n = 6 if self.output == "free6" else 3
        return torch.relu(NEURAL_OUTPUT_SCALE * outputs[:, :n] - 1.0).sum(-1).mean()

    def deviation(self, outputs: torch.Tensor) -> torch.Tensor:
        """How far the direct-light corrections of :meth:`network_outputs` ``outputs`` leave the
        split-sum base either way: the mean over pixels of the sum over the corrections of
        (S k - 1)^2 (the indirect factor excluded). The penalty of
        ``TrainConfig.student_direct_penalty``: a student that reads only the material and n.v
        has no evidence of the scene's visibility, so a direct correction it learns is a change of
        the BRDF (the white furnace sees it), not of the light."""
        n = 6 if self.output == "free6" else 3
        return ((NEURAL_OUTPUT_SCALE * outputs[:, :n] - 1.0) ** 2).sum(-1).mean()

    def weights(self, x: torch.Tensor, outputs: torch.Tensor | None = None) -> torch.Tensor:
        """``x [N, k]`` (:data:`ALL_INPUTS` order, :meth:`select`) -> the factors ``k [N, 6]``
        (``free6``: k_diffuse rgb, k_specular rgb) or ``[N, 3]`` (``pbr3``: k_d, k_a, k_b) in
        [0, 1], ``[N, 4]`` with the indirect light's k_i last (:attr:`learns_indirect`); with
        ``occlusion == "factor"`` the diffuse factor(s) times the ao input x[:, 6].
        ``outputs``: :meth:`network_outputs` of ``x`` when already computed."""
        k = self.network_outputs(x) if outputs is None else outputs
        if self.occlusion == "input":
            return k
        n_diffuse = 3 if self.output == "free6" else 1
        return torch.cat([k[:, :n_diffuse] * x[:, 6:7], k[:, n_diffuse:]], dim=-1)

    def indirect_factor(self, x: torch.Tensor) -> torch.Tensor:
        """The factor ``[N]`` on the screen-space indirect light (lighting pass's second output,
        ``neural_indirect_factor``): S k_i, 1 for a student without one."""
        if not self.learns_indirect:
            return torch.ones(x.shape[0], dtype=x.dtype)
        return neural_indirect_factor(self.weights(x)[:, 3])

    def forward(self, x: torch.Tensor, irradiance: torch.Tensor, prefiltered: torch.Tensor,
                indirect: torch.Tensor | None = None, sun: torch.Tensor | None = None,
                with_gain: bool = False, with_deviation: bool = False):
        """Radiance ``[N, 3]`` from :func:`learned.neural.lighting.student_features` (``x`` holds
        albedo, roughness, metallic, specular first: the material of the ``pbr3`` form): the
        lighting pass's direct light, plus ``indirect`` (``[N, 3]``, the indirect pass's
        one-bounce light L_ind) times :meth:`indirect_factor` when given. ``sun`` ``[N, 13]``
        (``student_features(..., sun=True)``; a student with :attr:`sun` only): the
        environment's sun, shaded with the same factors (``neural_student_sun_split``).
        ``with_gain``: returns (radiance, :meth:`gain`) from the one evaluation (so that a
        DistributedDataParallel wrapper sees a single forward); ``with_deviation`` as well:
        (radiance, gain, :meth:`deviation`)."""
        outputs = self.network_outputs(x)
        k = self.weights(x, outputs)
        out = self._shade(k, x, irradiance, prefiltered, indirect, sun)
        if with_deviation:
            return out, self.gain(outputs), self.deviation(outputs)
        return (out, self.gain(outputs)) if with_gain else out

    def _shade(self, k, x, irradiance, prefiltered, indirect, sun):
        out = self._radiance(k[:, :6 if self.output == "free6" else 3], x, irradiance,
                             prefiltered)
        if self.sun and sun is not None:
            out = out + self._sun(k[:, :3], x, sun)
        if indirect is None:
            return out
        if self.learns_indirect:
            return out + neural_indirect_factor(k[:, 3:4]) * indirect
        return out + indirect

    def _radiance(self, k, x, irradiance, prefiltered):
        albedo = x[:, :3]
        if self.output == "free6":
            return neural_student_radiance(k[:, :3], k[:, 3:], albedo, irradiance, prefiltered)
        metallic, specular = x[:, 4], x[:, 5]
        f0 = compute_f0(albedo, metallic, specular)
        if self.output == "split3":  # x[:, 8:10]: the DFG LUT (ALL_INPUTS order)
            return neural_student_radiance_split(k, diffuse_color(albedo, metallic), f0,
                                                 f90_from_f0(f0), x[:, 8:10], irradiance,
                                                 prefiltered, self._spec_scale(x[:, 8:10], f0))
        return neural_student_radiance_pbr(k, diffuse_color(albedo, metallic), f0,
                                           f90_from_f0(f0), irradiance, prefiltered)

    def _sun(self, k, x, sun):
        albedo, metallic, specular = x[:, :3], x[:, 4], x[:, 5]
        f0 = compute_f0(albedo, metallic, specular)
        r = clamp_perceptual_roughness(x[:, 3])
        return neural_student_sun_split(k, diffuse_color(albedo, metallic), f0, f90_from_f0(f0),
                                        x[:, 8:10], r * r, sun[:, 0:3], sun[:, 3:6], sun[:, 6:9],
                                        sun[:, 9:12], sun[:, 12], self._spec_scale(x[:, 8:10], f0))

    def _spec_scale(self, dfg, f0):
        """The split3 base's multiple-scattering compensation (``ibl_energy_compensation``) or 1."""
        return ibl_energy_compensation(dfg, f0) if self.multiscatter else torch.ones_like(f0)

    def networks(self) -> dict[str, list[tuple[torch.Tensor, torch.Tensor, str]]]:
        """name -> [(weight [out, in], bias [out], activation)] as exported."""
        nets = {"mlp": [(l.weight, l.bias, a) for l, a in zip(self.layers, self.activations())]}
        if self.learns_indirect:
            nets["indirect"] = [(l.weight, l.bias, a)
                                for l, a in zip(self.indirect_layers, ("relu", "sigmoid"))]
        return nets

    def macs_per_pixel(self) -> int:
        return sum(l.in_features * l.out_features
                   for l in (*self.layers, *self.indirect_layers))

    def parameter_count(self) -> int:
        return sum(p.numel() for p in self.parameters())
