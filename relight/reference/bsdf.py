"""Our BSDF as a Mitsuba 3 plugin written in Python, so the path-traced reference differs from the
rasteriser's models only by what those approximate (visibility, inter-reflection, the split-sum
and SH approximations), never by the material model.

The BSDF is the one ``ggx_mc`` integrates and ``ggx_split_sum`` approximates
(``shaders/lib/shading.glsl``, ``ggx_directional_light``), evaluated exactly:

    f cos = [diffuse (1 - E_spec(n.v)) / pi
             + D_GGX(h) V_SmithGGXCorrelated(v, l) F_Schlick(v.h) c_ms] n.l

with perceptual roughness clamped to 0.045 (alpha = r^2), f0 = mix(0.16 specular^2, albedo,
metallic), f90 = saturate(16.5 (f0.r + f0.g + f0.b)) (a material with glTF's dielectric lobe,
``Material.ior`` from ``KHR_materials_ior`` / ``_specular``: f0 = mix(F0, albedo, metallic),
f90 = mix(F90, 1, metallic) with F0 = min(((ior - 1) / (ior + 1))^2 specular_color, 1)
specular_factor and F90 = specular_factor, the colour and factor times their maps; lib/brdf.glsl
``surface_f0_f90``), diffuse = albedo (1 - metallic), the
specular directional albedo E_spec = (f0 (y - x) + f90 x) c_ms and the multiple-scattering
compensation c_ms = 1 + f0 (1 / y - 1) (1 without ``multiscatter``), where (x, y) = DFG(n.v, r).
The DFG terms come from :func:`directional_albedo_table`, a float64 quadrature of the same
integral the renderer's LUT estimates with 4096 Hammersley samples (the two agree to 0.4 %).

A ``KHR_materials_clearcoat`` coat is layered over this as :mod:`relight.reference.layers` says
(the base keeps 1 - w of itself, w = c F_c(n.v); shaders/lib/layers.glsl), a
``KHR_materials_sheen`` sheen between them as :mod:`relight.reference.sheen` says, a
``KHR_materials_iridescence`` film changes the Fresnel term and E_spec as
:mod:`relight.reference.iridescence` says, and
``KHR_materials_transmission`` / ``_volume`` split the base's non-specular part as
:mod:`relight.reference.transmission` says (seen from both sides;
shaders/lib/transmission.glsl), and ``KHR_materials_anisotropy`` stretches the specular lobe as
:mod:`relight.reference.anisotropy` says.

Not modelled here, on purpose: the material's ``ao`` and glTF occlusion maps (baked visibility:
the path tracer computes visibility itself), and the rasteriser's bending of back-facing shading
normals towards the viewer (``shading_normal``): a path tracer sees no such normals on the
primitives the fidelity tests use. Normal maps perturb the shading frame (``_frame``).
"""
from __future__ import annotations

import functools

from .anisotropy import anisotropic_dv, anisotropic_pdf, anisotropic_sample, anisotropy_state
from .iridescence import film_albedo_delta, film_fresnel_mix, film_state
from .layers import coat_eval, coat_pdf, coat_state
from .quadrature import DFG_TABLE_SIZE, MIN_PERCEPTUAL_ROUGHNESS, directional_albedo_table
from .quadrature import brdf_cos_numpy  # noqa: F401 (the plugin's formula in numpy, for tests)
from .transmission import (attenuation, btdf_cos_rgb, btdf_pdf_rgb, btdf_sample_rgb, facing,
                           mirror_z, transmission_state)
from .sheen import sheen_eval, sheen_pdf, sheen_scaling, sheen_state, table_texture

def bsdf_class(mi, dr):
    """The plugin class for the active Mitsuba variant (a class derives from ``mi.BSDF``, which
    exists only once a variant is set, and differs between variants)."""
    return _bsdf_class(mi, dr, mi.variant())


@functools.lru_cache(maxsize=None)
def _bsdf_class(mi, dr, variant: str):

    class WorkbenchBSDF(mi.BSDF):
        """Lambert + height-correlated GGX with our energy split (module docstring). Constant
        parameters, optionally times texture maps evaluated at the hit's UV (glTF conventions:
        ``base_color`` linear RGB; ``metallic_roughness`` G = roughness, B = metallic;
        ``normal`` tangent space n/2 + 1/2)."""

        def __init__(self, props=None):
            mi.BSDF.__init__(self, props if props is not None else mi.Properties())
            diffuse = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            glossy = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
            self.m_components = [diffuse, glossy]
            self.m_flags = diffuse | glossy
            self.albedo = (0.8, 0.8, 0.8)
            self.roughness = 0.5
            self.metallic = 0.0
            self.specular = 0.5
            self.multiscatter = False
            self.base_color_texture = None
            self.metallic_roughness_texture = None
            self.normal_texture = None
            self.normal_scale = 1.0
            self.dfg = None
            self.material = None
            self.specular_texture = None
            self.specular_color_texture = None
            self.clearcoat_texture = self.clearcoat_roughness_texture = None
            self.sheen_color_texture = self.sheen_roughness_texture = self.sheen_table = None
            self.anisotropy_texture = None
            self.iridescence_texture = self.iridescence_thickness_texture = None
            self.transmission_texture = None

        def configure(self, material, textures: dict, multiscatter: bool,
                      normal_scale: float = 1.0):
            self.albedo = tuple(float(c) for c in material.albedo)
            self.roughness = float(material.roughness)
            self.metallic = float(material.metallic)
            self.specular = float(material.specular)
            self.multiscatter = bool(multiscatter)
            self.base_color_texture = textures.get("base_color")
            self.metallic_roughness_texture = textures.get("metallic_roughness")
            self.normal_texture = textures.get("normal")
            self.normal_scale = float(normal_scale)
            self.material = material  # its glTF dielectric lobe (ior, specular colour, factor)
            self.specular_texture = textures.get("specular")  # the map's A, in all three
            self.specular_color_texture = textures.get("specular_color")
            self.clearcoat_texture = textures.get("clearcoat")  # R (KHR_materials_clearcoat)
            self.clearcoat_roughness_texture = textures.get("clearcoat_roughness")  # G
            self.sheen_color_texture = textures.get("sheen_color")  # KHR_materials_sheen
            self.sheen_roughness_texture = textures.get("sheen_roughness")  # the map's A
            self.anisotropy_texture = textures.get("anisotropy")  # RG direction, B strength
            self.iridescence_texture = textures.get("iridescence")  # R (KHR_materials_iridescence)
            self.iridescence_thickness_texture = textures.get("iridescence_thickness")  # its G
            # R (KHR_materials_transmission); KHR_materials_volume's thickness map is not read:
            # the traced volume is the mesh, whose thickness the map approximates for rasterisers
            self.transmission_texture = textures.get("transmission")
            if max(material.sheen_color) > 0.0:
                self.sheen_table = table_texture(mi, dr)
            if material.transmission > 0.0:  # seen from both sides, light passes through
                through = mi.BSDFFlags.GlossyTransmission | mi.BSDFFlags.BackSide
                self.m_components.append(through | mi.BSDFFlags.FrontSide)
                self.m_flags = self.m_flags | through
            table = directional_albedo_table()
            self.dfg = mi.Texture2f(mi.TensorXf(table), use_accel=False,
                                    filter_mode=dr.FilterMode.Linear,
                                    wrap_mode=dr.WrapMode.Clamp)
            return self

        # ---- the material at a hit --------------------------------------------------------
        def _frame(self, si):
            """The normal-mapped shading frame in the local coordinates of ``si.sh_frame``
            (glTF tangent space: x along du, y along -dv, the map's xy scaled by
            ``normal_scale``), built from the UV derivatives as the G-buffer pass's cotangent
            frame is (Schueler 2013); None without a normal map."""
            if self.normal_texture is None:
                return None
            c = self.normal_texture.eval(si)
            x = (2.0 * c.x - 1.0) * self.normal_scale
            y = (2.0 * c.y - 1.0) * self.normal_scale
            z = 2.0 * c.z - 1.0
            du = si.sh_frame.to_local(si.dp_du)
            dv = si.sh_frame.to_local(si.dp_dv)
            t = mi.Vector3f(du.x, du.y, 0.0)
            b = -mi.Vector3f(dv.x, dv.y, 0.0)
            scale = dr.rsqrt(dr.maximum(dr.maximum(dr.squared_norm(t), dr.squared_norm(b)),
                                        1e-30))
            n = dr.normalize(t * (x * scale) + b * (y * scale) + mi.Vector3f(0.0, 0.0, 1.0) * z)
            # a mapped normal facing away from the viewer is bent towards it until n.v = 1e-4,
            # as the rasteriser's shading_normal (lib/shading.glsl) and glTF viewers' clamped
            # n.v shade it; left as it is, every direction is "below" it and the pixel is black
            # (the plasma gun's grazing barrel: 12 pixels of zero radiance, zero variance)
            nv = dr.dot(n, si.wi)
            n = dr.select(nv < 1e-4, dr.normalize(n + (1e-4 - nv) * si.wi), n)
            return mi.Frame3f(n)

        def _surface(self, si, t=None):
            albedo = mi.Color3f(*self.albedo)
            if self.base_color_texture is not None:
                albedo = albedo * self.base_color_texture.eval(si)
            rough = mi.Float(self.roughness)
            metal = mi.Float(self.metallic)
            if self.metallic_roughness_texture is not None:
                mr = self.metallic_roughness_texture.eval(si)
                rough = rough * mr.y
                metal = metal * mr.z
            metal = dr.clip(metal, 0.0, 1.0)
            r = dr.clip(rough, MIN_PERCEPTUAL_ROUGHNESS, 1.0)
            a = r * r
            f0, f90 = self._fresnel(si, albedo, metal)
            frame = self._frame(si)
            wi = si.wi if frame is None else frame.to_local(si.wi)
            nov = mi.Frame3f.cos_theta(wi)
            n = DFG_TABLE_SIZE
            uv = mi.Point2f((dr.clip(nov, 0.0, 1.0) * (n - 1) + 0.5) / n, (r * (n - 1) + 0.5) / n)
            x, y = self.dfg.eval(uv)
            if self.multiscatter:
                c_ms = 1.0 + f0 * (1.0 / dr.maximum(y, 1e-4) - 1.0)
            else:
                c_ms = mi.Color3f(1.0)
            e_spec = f0 * (y - x) + f90 * x
            film = film_state(mi, dr, self, si)
            if film is not None:  # what the film changes in E_spec (its Fresnel: _eval, per v.h)
                e_spec = e_spec + film_albedo_delta(mi, dr, film, f0, f90, nov, a)
            e_spec = e_spec * c_ms
            kd = albedo * (1.0 - metal) * dr.maximum(1.0 - e_spec, 0.0)
            p_trans = 0.0 if t is None else t["T"]  # the BTDF's share of the base's kd
            transmit, kd = kd * p_trans, kd * (1.0 - p_trans)
            lum = mi.Color3f(0.2126, 0.7152, 0.0722)
            ls = dr.sum(e_spec * lum)
            ld = dr.sum((kd + transmit) * lum)
            p_spec = dr.select(ls + ld > 0.0, ls / dr.maximum(ls + ld, 1e-12), 1.0)
            # keep both lobes reachable when both carry energy (unbiased either way)
            p_spec = dr.select((ld > 0.0) & (ls > 0.0), dr.clip(p_spec, 0.05, 0.95), p_spec)
            coat = coat_state(mi, dr, self, si, self.dfg, DFG_TABLE_SIZE)
            if coat is not None:  # lobe choice: the coat by its albedo against the base's
                base = (1.0 - coat["w"]) * (ls + ld)
                coat["p"] = dr.select(coat["albedo"] + base > 0.0, coat["albedo"]
                                      / dr.maximum(coat["albedo"] + base, 1e-12), 0.0)
                coat["p"] = dr.select((coat["albedo"] > 0.0) & (base > 0.0),
                                      dr.clip(coat["p"], 0.05, 0.95), coat["p"])
            return dict(aniso=anisotropy_state(mi, dr, self, si, frame, a),
                        a=a, f0=f0, f90=f90, c_ms=c_ms, kd=kd, p_spec=p_spec, nov=nov, wi=wi,
                        frame=frame, coat=coat, t=t, transmit=transmit, p_trans=p_trans,
                        sheen=sheen_state(mi, dr, self, si, wi, ls + ld), film=film)

        def _fresnel(self, si, albedo, metal):
            """f0 and f90 at the hit: lib/brdf.glsl ``surface_f0_f90`` (module docstring)."""
            m = self.material
            if m is None or m.ior is None:
                f0d = 0.16 * self.specular * self.specular
                f0 = dr.lerp(mi.Color3f(f0d), albedo, metal)
                return f0, dr.clip((f0.x + f0.y + f0.z) * (50.0 * 0.33), 0.0, 1.0)
            color = mi.Color3f(*m.specular_color)
            if self.specular_color_texture is not None:
                color = color * self.specular_color_texture.eval(si)
            factor = mi.Float(m.specular_factor)
            if self.specular_texture is not None:
                factor = factor * self.specular_texture.eval(si).x
            ior = float(m.ior)
            f0_ior = 1.0 if ior == 0.0 else ((ior - 1.0) / (ior + 1.0)) ** 2
            f0d = dr.minimum(f0_ior * color, 1.0) * factor
            return dr.lerp(f0d, albedo, metal), dr.lerp(factor, 1.0, metal)

        @staticmethod
        def _to_mapped(s, wo):
            return wo if s["frame"] is None else s["frame"].to_local(wo)

        @staticmethod
        def _from_mapped(s, wo):
            return wo if s["frame"] is None else s["frame"].to_world(wo)

        def _eval(self, s, si, wo):
            """f cos for ``wo`` in the mapped frame (``s["wi"]`` too)."""
            wi = s["wi"]
            nol = mi.Frame3f.cos_theta(wo)
            nov = s["nov"]
            h = dr.normalize(wi + wo)
            noh = dr.clip(mi.Frame3f.cos_theta(h), 0.0, 1.0)
            voh = dr.clip(dr.dot(wi, h), 0.0, 1.0)
            a2 = dr.maximum(s["a"] * s["a"], 1e-8)
            # D's bracket NoH^2 a^2 + (1 - NoH^2), with 1 - NoH^2 = h.x^2 + h.y^2 in the local
            # frame: exact near the peak, where 1 - NoH computed from NoH ~ 1 in float32 keeps
            # few digits (about 6 % at roughness 0.05, whose lobe lies within 1e-6 of NoH = 1)
            # and the error would depend on the CPU's vector code; sample()'s density
            # (Mitsuba's GGX, from h's components too) then matches this value
            f = noh * noh * a2 + (h.x * h.x + h.y * h.y)
            d = a2 / (dr.pi * f * f)
            nl = dr.clip(nol, 0.0, 1.0)
            nv = dr.clip(nov, 0.0, 1.0)
            vis = 0.5 / dr.maximum(nl * dr.sqrt(nv * nv * (1.0 - a2) + a2)
                                   + nv * dr.sqrt(nl * nl * (1.0 - a2) + a2), 1e-8)
            x5 = dr.power(1.0 - voh, 5)
            fr = s["f0"] + (s["f90"] - s["f0"]) * x5
            if s["aniso"] is not None:  # KHR_materials_anisotropy: the stretched lobe's D V
                d, vis = anisotropic_dv(mi, dr, s["aniso"], wi, wo, h), 1.0
            if s["film"] is not None:
                fr = film_fresnel_mix(mi, dr, s["film"], s["f0"], s["f90"], voh)
            value = (s["kd"] * dr.inv_pi + d * vis * fr * s["c_ms"]) * nl
            ok = (nol > 0.0) & (nov > 0.0)
            return dr.select(ok, value, 0.0)

        def _pdf(self, s, si, wo, distr):
            """Density of ``wo`` (mapped frame) under :meth:`sample`."""
            wi = s["wi"]
            nol = mi.Frame3f.cos_theta(wo)
            h = dr.normalize(wi + wo)
            p_spec_dir = distr.pdf(wi, h) / dr.maximum(4.0 * dr.dot(wo, h), 1e-12)
            if s["aniso"] is not None:
                p_spec_dir = anisotropic_pdf(mi, dr, s["aniso"], wi, wo)
            p_diff = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            p = s["p_spec"] * p_spec_dir + (1.0 - s["p_spec"]) * (1.0 - s["p_trans"]) * p_diff
            ok = (nol > 0.0) & (mi.Frame3f.cos_theta(wi) > 0.0)
            t = s["t"]
            if t is None:
                return dr.select(ok, p, 0.0)
            p_t = btdf_pdf_rgb(mi, dr, distr, t, wi, wo)
            return dr.select(ok, p, (1.0 - s["p_spec"]) * s["p_trans"] * p_t)

        # ---- the mi.BSDF interface ---------------------------------------------------------
        # Directions arrive and leave in si.sh_frame's coordinates; with a normal map they are
        # turned into the mapped frame. A direction below the interpolated surface but above the
        # mapped one is *not* rejected (Mitsuba's normalmap adapter rejects it): the rasteriser's
        # models take light from the whole mapped hemisphere, and whether such light is blocked
        # is left to the traced geometry (a closed mesh blocks it, a thin sheet does not).
        def _layered(self, s, si, wo_local, distr):
            """(f cos, pdf) of the whole material for ``wo`` in si.sh_frame's coordinates: the
            base (in the mapped frame) and, with a coat, (1 - w) of it plus the coat
            (relight.reference.layers)."""
            wm = self._to_mapped(s, wo_local)
            value, pdf = self._eval(s, si, wm), self._pdf(s, si, wm, distr)
            if s["t"] is not None:  # below: the BTDF (the base's value and density are 0 there)
                value += s["transmit"] * btdf_cos_rgb(mi, dr, s["a"], s["t"], s["wi"], wm)
            sh = s["sheen"]
            if sh is not None:  # the sheen over the base, in the base's (mapped) frame
                value = value * sheen_scaling(mi, dr, self, sh, wm) + sheen_eval(mi, dr, sh,
                                                                                 s["wi"], wm)
                pdf = sh["p"] * sheen_pdf(mi, dr, s["wi"], wm) + (1.0 - sh["p"]) * pdf
            c = s["coat"]
            if c is None:
                return value, pdf
            return ((1.0 - c["w"]) * value + coat_eval(mi, dr, c, si.wi, wo_local),
                    c["p"] * coat_pdf(mi, dr, c, si.wi, wo_local) + (1.0 - c["p"]) * pdf)

        def _facing(self, si):
            """``si`` seen from the viewer's side (mirrored from a transmissive back face) and
            the transmission state, None for an opaque material."""
            t = transmission_state(mi, dr, self.material, si, self.transmission_texture)
            if t is None:
                return si, None
            si, t["eta"] = facing(mi, dr, t, si)
            return si, t

        def sample(self, ctx, si_in, sample1, sample2, active=True):
            si, t = self._facing(si_in)
            s = self._surface(si, t)
            wi = s["wi"]
            distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, s["a"], True)
            c = s["coat"]
            on_coat = mi.Bool(False)
            if c is not None:  # the coat first, the rest of sample1 chooses the base's lobe
                on_coat = sample1 < c["p"]
                sample1 = dr.select(on_coat, 0.0, (sample1 - c["p"])
                                    / dr.maximum(1.0 - c["p"], 1e-12))
            sh, on_sheen = s["sheen"], mi.Bool(False)
            if sh is not None:  # then the sheen (uniform over the hemisphere), then the base
                on_sheen = sample1 < sh["p"]
                sample1 = dr.select(on_sheen, 0.0, (sample1 - sh["p"])
                                    / dr.maximum(1.0 - sh["p"], 1e-12))
            spec = sample1 < s["p_spec"]
            m, _ = distr.sample(wi, sample2)
            wo_spec = mi.reflect(wi, m)
            if s["aniso"] is not None:
                wo_spec = anisotropic_sample(mi, dr, s["aniso"], wi, sample2)
            wo_diff = mi.warp.square_to_cosine_hemisphere(sample2)
            wo_m = dr.select(on_sheen, mi.warp.square_to_uniform_hemisphere(sample2),
                             dr.select(spec, wo_spec, wo_diff))
            keep = mi.Bool(True)  # each lobe keeps only its own hemisphere's draws (.transmission)
            if t is not None:
                u = (sample1 - s["p_spec"]) / dr.maximum(1.0 - s["p_spec"], 1e-12)
                through = ~spec & ~on_sheen & (u < s["p_trans"])
                u_channel = u / dr.maximum(s["p_trans"], 1e-12)  # the rest of u: a channel
                wo_m = dr.select(through, btdf_sample_rgb(mi, dr, distr, t, wi, sample2,
                                                          u_channel), wo_m)
                keep = dr.select(through, wo_m.z < 0.0, wo_m.z > 0.0)
            wo = self._from_mapped(s, wo_m)
            spec = spec | on_sheen
            if c is not None:
                mc, _ = c["distr"].sample(si.wi, sample2)
                wo = dr.select(on_coat, mi.reflect(si.wi, mc), wo)
                if t is not None:
                    keep = dr.select(on_coat, mi.Frame3f.cos_theta(wo) > 0.0, keep)
                spec = spec | on_coat
            value, pdf = self._layered(s, si, wo, distr)
            if t is not None:
                value, wo = value * attenuation(mi, dr, t, si_in), mirror_z(mi, dr, t, wo)
                pdf = dr.select(keep, pdf, 0.0)
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_type = dr.select(spec, mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                        mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
            bs.sampled_component = dr.select(spec, mi.UInt32(1), mi.UInt32(0))
            ok = active & (pdf > 0.0) & keep
            return bs, dr.select(ok, value / dr.maximum(pdf, 1e-20), 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[1]

        def eval_pdf(self, ctx, si_in, wo, active=True):
            si, t = self._facing(si_in)
            s = self._surface(si, t)
            distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, s["a"], True)
            if t is not None:
                wo = mirror_z(mi, dr, t, wo)
            value, pdf = self._layered(s, si, wo, distr)
            if t is not None:
                value = value * attenuation(mi, dr, t, si_in)
            return dr.select(active, value, 0.0), dr.select(active, pdf, 0.0)

        def traverse(self, callback):
            pass

        def to_string(self):
            return (f"WorkbenchBSDF[albedo={self.albedo}, roughness={self.roughness}, "
                    f"metallic={self.metallic}, specular={self.specular}, "
                    f"multiscatter={self.multiscatter}]")

    return WorkbenchBSDF
