"""PBR material parameters (metallic-roughness, Filament conventions)."""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import SceneError


@dataclass(frozen=True)
class Material:
    albedo: tuple[float, float, float] = (0.8, 0.8, 0.8)  # linear RGB base colour
    roughness: float = 0.5  # perceptual roughness r; alpha = r^2
    metallic: float = 0.0
    specular: float = 0.5  # dielectric f0 = 0.16 * specular^2 (0.5 -> 0.04); 0 = no specular lobe
    ao: float = 1.0

    def validated(self, where: str = "material") -> "Material":
        vals = {"roughness": self.roughness, "metallic": self.metallic,
                "specular": self.specular, "ao": self.ao}
        for k, v in vals.items():
            if not (0.0 <= float(v) <= 1.0):
                raise SceneError(f"{k} = {v} is outside [0, 1]", where=where)
        if len(self.albedo) != 3 or not all(0.0 <= float(c) <= 1.0 for c in self.albedo):
            raise SceneError(f"albedo = {list(self.albedo)} must be 3 numbers in [0, 1]", where=where)
        return self
