"""PBR material parameters (metallic-roughness, Filament conventions, and the dielectric lobe of
glTF's ``KHR_materials_ior`` / ``KHR_materials_specular``)."""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import SceneError


@dataclass(frozen=True)
class Material:
    albedo: tuple[float, float, float] = (0.8, 0.8, 0.8)  # linear RGB base colour
    roughness: float = 0.5  # perceptual roughness r; alpha = r^2
    metallic: float = 0.0
    specular: float = 0.5  # dielectric f0 = 0.16 * specular^2 (0.5 -> 0.04); 0 = no specular lobe
    ao: float = 1.0
    # KHR_materials_ior / KHR_materials_specular: None = the dielectric lobe is Filament's
    # `specular` above; a number (>= 1, or 0 for the extension's "infinite" IOR) = the lobe is
    # glTF's, F0 = min(((ior - 1) / (ior + 1))^2 specular_color, 1) specular_factor,
    # F90 = specular_factor (`specular` is then unused)
    ior: float | None = None
    specular_color: tuple[float, float, float] = (1.0, 1.0, 1.0)  # linear RGB, >= 0
    specular_factor: float = 1.0  # in [0, 1]
    # KHR_materials_clearcoat: a GGX coat of IOR 1.5 over the base (0 = none; shaders/lib/layers.glsl)
    clearcoat: float = 0.0  # in [0, 1]
    clearcoat_roughness: float = 0.0  # perceptual, in [0, 1]
    # KHR_materials_transmission: the share of the dielectric base that is a specular BTDF
    # instead of diffuse (0 = opaque; shaders/lib/transmission.glsl)
    transmission: float = 0.0  # in [0, 1]
    # KHR_materials_volume: thickness 0 = thin-walled (no refraction, no attenuation); > 0 = the
    # mesh bounds a volume (refraction at entry and exit, Beer-Lambert attenuation inside)
    thickness: float = 0.0  # thicknessFactor, >= 0 (its size matters to the rasteriser only)
    attenuation_color: tuple[float, float, float] = (1.0, 1.0, 1.0)  # linear RGB in [0, 1]
    attenuation_distance: float = math.inf  # > 0: the distance at which white becomes the colour
    # KHR_materials_sheen: a Charlie sheen of this linear colour over the base (0 = none;
    # shaders/lib/layers.glsl) and its roughness (alpha = r^2)
    sheen_color: tuple[float, float, float] = (0.0, 0.0, 0.0)  # in [0, 1]
    sheen_roughness: float = 0.0  # in [0, 1]
    # KHR_materials_anisotropy: the specular lobe's alpha along the direction grows to
    # mix(r^2, 1, strength^2) (0 = isotropic; shaders/lib/anisotropy.glsl); the direction is the
    # tangent turned by the rotation (radians, counter-clockwise towards the bitangent)
    anisotropy_strength: float = 0.0  # in [0, 1]
    anisotropy_rotation: float = 0.0  # radians, finite
    # KHR_materials_iridescence: a thin film of this strength (0 = none; shaders/lib/iridescence.glsl),
    # IOR and thickness in nm (the thickness map's G blends min to max; without it: max)
    iridescence: float = 0.0  # in [0, 1]
    iridescence_ior: float = 1.3  # >= 1
    iridescence_thickness_min: float = 100.0  # nm, >= 0
    iridescence_thickness_max: float = 400.0  # nm, >= 0
    # KHR_materials_dispersion: 20 / V_d (the Abbe number; 0 = none): a volume refracts each
    # colour channel by its own IOR (dispersion_iors, lib/transmission.glsl); no effect without
    # a volume (the spec)
    dispersion: float = 0.0  # >= 0, finite

    def validated(self, where: str = "material") -> "Material":
        vals = {"roughness": self.roughness, "metallic": self.metallic,
                "specular": self.specular, "ao": self.ao, "specular_factor": self.specular_factor,
                "clearcoat": self.clearcoat, "clearcoat_roughness": self.clearcoat_roughness,
                "transmission": self.transmission,
                "sheen_roughness": self.sheen_roughness,
                "anisotropy_strength": self.anisotropy_strength, "iridescence": self.iridescence}
        for k, v in vals.items():
            if not (0.0 <= float(v) <= 1.0):
                raise SceneError(f"{k} = {v} is outside [0, 1]", where=where)
        if len(self.albedo) != 3 or not all(0.0 <= float(c) <= 1.0 for c in self.albedo):
            raise SceneError(f"albedo = {list(self.albedo)} must be 3 numbers in [0, 1]", where=where)
        if len(self.sheen_color) != 3 or not all(0.0 <= float(c) <= 1.0 for c in self.sheen_color):
            raise SceneError(f"sheen_color = {list(self.sheen_color)} must be 3 numbers in [0, 1]",
                             where=where)
        if self.ior is not None and not (float(self.ior) == 0.0 or
                                         1.0 <= float(self.ior) < math.inf):
            raise SceneError(f"ior = {self.ior} must be 0 (infinite) or a finite number >= 1",
                             where=where)
        if len(self.specular_color) != 3 or not all(
                0.0 <= float(c) < math.inf for c in self.specular_color):
            raise SceneError(f"specular_color = {list(self.specular_color)} must be 3 finite "
                             f"numbers >= 0", where=where)
        if not (1.0 <= float(self.iridescence_ior) < math.inf):
            raise SceneError(f"iridescence_ior = {self.iridescence_ior} must be a finite number "
                             f">= 1", where=where)
        for k in ("iridescence_thickness_min", "iridescence_thickness_max"):
            if not (0.0 <= float(getattr(self, k)) < math.inf):
                raise SceneError(f"{k} = {getattr(self, k)} must be a finite number >= 0 (nm)",
                                 where=where)
        if not (0.0 <= float(self.thickness) < math.inf):
            raise SceneError(f"thickness = {self.thickness} must be a finite number >= 0",
                             where=where)
        if len(self.attenuation_color) != 3 or not all(
                0.0 <= float(c) <= 1.0 for c in self.attenuation_color):
            raise SceneError(f"attenuation_color = {list(self.attenuation_color)} must be 3 "
                             f"numbers in [0, 1]", where=where)
        if not (0.0 <= float(self.dispersion) < math.inf):
            raise SceneError(f"dispersion = {self.dispersion} must be a finite number >= 0",
                             where=where)
        if not math.isfinite(float(self.anisotropy_rotation)):
            raise SceneError(f"anisotropy_rotation = {self.anisotropy_rotation} must be a finite "
                             f"number (radians)", where=where)
        if not float(self.attenuation_distance) > 0.0:
            raise SceneError(f"attenuation_distance = {self.attenuation_distance} must be > 0 "
                             f"(inf: no attenuation)", where=where)
        return self

    @property
    def volume(self) -> bool:
        """Whether light refracts into a volume (KHR_materials_volume with thickness > 0)."""
        return self.transmission > 0.0 and self.thickness > 0.0

    def transmission_row(self) -> tuple[float, float, float, float]:
        """The traced material's transmission: (factor, the volume's IOR or 0 for a thin wall,
        the ray tracer's and the reference's eta; the volume's dispersion (0 without one); 0)."""
        return (float(self.transmission), self.volume_ior() if self.volume else 0.0,
                float(self.dispersion) if self.has_dispersion else 0.0, 0.0)

    @property
    def has_dispersion(self) -> bool:
        """KHR_materials_dispersion with an effect: dispersion > 0 on a volume (the spec: only
        volumetric refraction disperses; a thin wall or an opaque surface ignores it)."""
        return self.dispersion > 0.0 and self.volume

    def volume_ior(self) -> float:
        """The IOR light refracts by: KHR_materials_ior's (1.5 without it; its 'infinite' 0
        would admit no light at all, so it refracts as 1.5 while reflecting as F0 = 1)."""
        return 1.5 if self.ior is None or self.ior == 0.0 else float(self.ior)

    def attenuation_coefficient(self) -> tuple[float, float, float]:
        """sigma_a per unit length, -ln(attenuation_color) / attenuation_distance (0 without
        a volume or at the default infinite distance; a colour channel of 0 absorbs all but a
        sliver: clamped at 1e-6)."""
        if not self.volume or math.isinf(self.attenuation_distance):
            return (0.0, 0.0, 0.0)
        return tuple(-math.log(max(float(c), 1e-6)) / float(self.attenuation_distance)
                     for c in self.attenuation_color)

    @property
    def has_sheen(self) -> bool:
        """KHR_materials_sheen: a sheen colour > 0 (the spec: zero disables the layer)."""
        return max(self.sheen_color) > 0.0

    @property
    def has_anisotropy(self) -> bool:
        """KHR_materials_anisotropy: a strength > 0 (0 leaves the lobe isotropic)."""
        return self.anisotropy_strength > 0.0

    @property
    def has_iridescence(self) -> bool:
        """KHR_materials_iridescence: a factor > 0 (the spec: zero, the default, disables it)."""
        return self.iridescence > 0.0

    def iridescence_row(self, thickness_map: bool = False) -> tuple[float, float, float, float]:
        """The G-buffer's ``iridescence`` channel for this material's factors: (factor, thickness
        in nm, film IOR) and, for a thickness map, the minimum (the map's G blends it to the
        maximum); the traced material's row (the thickness map's G, where there is one,
        blends the minimum to the maximum there too: passes/raytrace.glsl rt_surface)."""
        return (float(self.iridescence), float(self.iridescence_thickness_max),
                float(self.iridescence_ior), float(self.iridescence_thickness_min))

    def dielectric(self) -> tuple[float, float, float, float]:
        """The G-buffer's ``dielectric`` channel for this material's factors: (F0 rgb, F90) of
        ``shaders/lib/brdf.glsl`` ``dielectric_f0_ior``, or (0, 0, 0, -1) without ``ior`` (the
        channel's background: Filament's reflectance from ``specular``)."""
        return dielectric_row(self)


# the glTF extensions' fields: a scene file names them only where they differ from the default
EXTENSION_FIELDS = ("ior", "specular_color", "specular_factor", "clearcoat", "clearcoat_roughness",
                    "transmission", "thickness", "attenuation_color", "attenuation_distance",
                    "sheen_color", "sheen_roughness", "anisotropy_strength",
                    "anisotropy_rotation", "iridescence", "iridescence_ior",
                    "iridescence_thickness_min", "iridescence_thickness_max", "dispersion")


def dielectric_f0_ior(ior: float, specular_color, specular_factor: float
                      ) -> tuple[float, float, float]:
    """``dielectric_f0_ior`` of ``shaders/lib/brdf.glsl`` in float64 (ior 0: F0 = 1)."""
    f0 = 1.0 if ior == 0.0 else ((ior - 1.0) / (ior + 1.0)) ** 2
    return tuple(min(f0 * float(c), 1.0) * specular_factor for c in specular_color)


def dielectric_row(m: Material) -> tuple[float, float, float, float]:
    """(F0 rgb, F90) of ``m``'s glTF dielectric lobe, (0, 0, 0, -1) when it has none."""
    if m.ior is None:
        return (0.0, 0.0, 0.0, -1.0)
    return (*dielectric_f0_ior(float(m.ior), m.specular_color, float(m.specular_factor)),
            float(m.specular_factor))
