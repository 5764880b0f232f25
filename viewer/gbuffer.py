"""The G-buffer layout, declared once as data.

Everything else is derived from :data:`CHANNELS`: the GLSL ``GBuffer`` struct with its store
(``gbuffer_store``, for fill passes) and load (``gbuffer_load``, for lighting passes) functions, the
framebuffer attachments, and the numpy pack/unpack used by loaders, AOV output and datasets.

Channels (all linear, float):

================ === ==========================================================================
albedo           3   base colour, linear RGB in [0, 1]
alpha            1   coverage in [0, 1]; 0 = background
normal           3   unit normal, world space (image-space stacks: camera space = world space)
roughness        1   perceptual roughness r in [0, 1]; alpha = r^2
metallic         1   in [0, 1]
specular         1   dielectric reflectance: f0 = 0.16 * specular^2 (Filament); 0 = no
                     specular lobe (also its background value, so an omitted specular channel
                     means "no lobe")
ao               1   ambient occlusion in [0, 1], applied to diffuse light
depth            1   view-space depth, positive distance along the view axis (-z_vs);
                     0 = background
color            3   baked unlit colour (splats' SH colour); only allocated when a scene has
                     splats
emission         3   emitted radiance, linear RGB (glTF emissive x strength), added by every
                     lighting pass; only allocated when a scene has emissive surfaces
dielectric       4   the glTF dielectric lobe (KHR_materials_ior / _specular): rgb = F0,
                     a = F90 (shaders/lib/brdf.glsl ``surface_f0_f90``); background
                     (0, 0, 0, -1) = none (the scalar ``specular`` sets the lobe); only
                     allocated when a scene has such a material
clearcoat        4   KHR_materials_clearcoat: factor, perceptual roughness, the coat's normal
                     (octahedral, lib/layers.glsl oct_encode); background 0 = no coat; only
                     allocated when a scene has a coated material
transmission     1   KHR_materials_transmission's factor T; background 0 = opaque; only allocated
                     when a scene has a transmissive material (as the next)
transmission_ior 1   KHR_materials_volume: the IOR light refracts by, 0 = thin-walled
dispersion       1   KHR_materials_dispersion: 20 / V_d of a volume (0 = none); only allocated
                     when a scene has a dispersive volume
sheen            4   KHR_materials_sheen: colour (rgb, linear), roughness (a); background 0 = no
                     sheen; only allocated when a scene has a material with a sheen
anisotropy       2   KHR_materials_anisotropy: strength s times (cos, sin) of the direction's
                     angle in the frame of the stored normal (lib/anisotropy.glsl
                     anisotropy_encode); background 0 = isotropic; only allocated when a scene
                     has an anisotropic material
iridescence      3   KHR_materials_iridescence: factor, the film's thickness (nm), its IOR;
                     background 0 = no film; only allocated when a scene has an iridescent
                     material
================ === ==========================================================================

Bytes per pixel: channels are packed into RGBA attachments of 16 bytes per pixel (``f4``) or 8
(``f2``). The base layout (albedo .. depth) is 3 attachments: 48 B/px (24 at fp16). Each optional
channel a scene needs adds one attachment, +16 B/px (+8): ``color`` (splats), ``emission``
(emissive meshes), ``dielectric``, ``clearcoat`` and ``sheen`` (4 components each: a whole
attachment), so a scene with the glTF dielectric lobe pays 64 B/px (32) where one without it
pays 48 (24), one with both lobes 80 (40), a sheen alone 64 (32). ``transmission`` and
``transmission_ior`` (and ``dispersion``; 1 component each) fill free components of the attachments before them
(the colour and emission attachments have one each; the base layout one where ``ao`` is
omitted): +0 to +16 B/px (+8). The all-features layout is 8 attachments (128 B/px, 64 at fp16),
GL's guaranteed minimum of draw buffers: the transmission pair rides in the colour and emission
attachments, the sheen takes the eighth. ``anisotropy`` (2 components) and ``iridescence`` (3)
add up to one attachment each, +16 B/px (+8): 64 B/px (32) for a scene with one of them and no
other optional channel (the anisotropy shares an attachment with the transmission pair where
both are allocated). They have no room in the all-features layout, which carries them only for a
scene that has them, without the optional channels that scene does not use
(:func:`viewer.specialize.specialise`); a scene whose materials would need a ninth attachment is
one error naming the channels. Omitted channels shrink the
layout further. :meth:`GBufferLayout.bytes_per_pixel` gives any layout's figure.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .errors import SceneError


@dataclass(frozen=True)
class Channel:
    name: str
    components: int
    attachment: int  # colour attachment index
    offset: int  # first component within the attachment (rgba)
    background: tuple[float, ...]  # value where nothing was drawn
    meaning: str
    optional: bool = False  # allocated only when a scene needs it
    # in the GLSL GBuffer struct only when allocated (its uses sit under GBUFFER_HAS_<NAME>): a
    # scene without it compiles exactly the programs it compiled before the channel existed
    declared_when_allocated: bool = False


CHANNELS: tuple[Channel, ...] = (
    Channel("albedo", 3, 0, 0, (0.0, 0.0, 0.0), "base colour, linear RGB"),
    Channel("alpha", 1, 0, 3, (0.0,), "coverage"),
    Channel("normal", 3, 1, 0, (0.0, 0.0, 0.0), "unit normal, world space"),
    Channel("roughness", 1, 1, 3, (1.0,), "perceptual roughness"),
    Channel("metallic", 1, 2, 0, (0.0,), "metalness"),
    Channel("specular", 1, 2, 1, (0.0,), "dielectric reflectance, f0 = 0.16 s^2"),
    Channel("ao", 1, 2, 2, (1.0,), "ambient occlusion"),
    Channel("depth", 1, 2, 3, (0.0,), "view-space depth, positive in front of the camera"),
    Channel("color", 3, 3, 0, (0.0, 0.0, 0.0), "baked unlit colour, premultiplied", optional=True),
    Channel("emission", 3, 4, 0, (0.0, 0.0, 0.0), "emitted radiance, linear RGB", optional=True),
    Channel("dielectric", 4, 5, 0, (0.0, 0.0, 0.0, -1.0),
            "glTF dielectric lobe: F0 (rgb), F90 (a); a < 0 = none", optional=True),
    Channel("clearcoat", 4, 6, 0, (0.0, 0.0, 0.0, 0.0),
            "glTF clearcoat: factor, roughness, octahedral normal", optional=True),
    Channel("transmission", 1, 7, 0, (0.0,), "glTF transmission factor", optional=True),
    Channel("transmission_ior", 1, 7, 1, (0.0,), "glTF volume IOR, 0 = thin-walled",
            optional=True),
    Channel("dispersion", 1, 7, 2, (0.0,), "glTF dispersion 20 / V_d of a volume, 0 = none",
            optional=True, declared_when_allocated=True),
    Channel("sheen", 4, 7, 0, (0.0, 0.0, 0.0, 0.0),
            "glTF sheen: colour (rgb), roughness", optional=True, declared_when_allocated=True),
    Channel("anisotropy", 2, 8, 0, (0.0, 0.0),
            "glTF anisotropy: strength x (cos, sin) of its direction in the normal's frame",
            optional=True, declared_when_allocated=True),
    Channel("iridescence", 3, 8, 0, (0.0, 0.0, 0.0),
            "glTF iridescence: factor, film thickness (nm), film IOR", optional=True,
            declared_when_allocated=True),
)
CHANNEL_NAMES = tuple(c.name for c in CHANNELS)
MAX_ATTACHMENTS = 8  # GL_MAX_DRAW_BUFFERS' guaranteed minimum (llvmpipe's value)
_GLSL_TYPE = {1: "float", 2: "vec2", 3: "vec3", 4: "vec4"}


def _pack(channels: tuple[Channel, ...]) -> tuple[Channel, ...]:
    """Assign attachments and offsets: declaration order, first RGBA attachment with room."""

    used: list[int] = []  # components used per attachment
    out = []
    for c in channels:
        for a, n in enumerate(used):
            if n + c.components <= 4:
                break
        else:
            used.append(0)
            a = len(used) - 1
        out.append(replace(c, attachment=a, offset=used[a]))
        used[a] += c.components
    return tuple(out)
_SWIZZLE = "rgba"


@dataclass(frozen=True)
class GBufferLayout:
    """The channels a scene needs and their render-target precision (``"f4"`` or ``"f2"``).

    ``omit`` names channels this scene does not need (a diffuse-only scene has no use for
    roughness, metallic and specular; depth is only read by screen-space passes): they are not
    allocated and read back as their background value. The kept channels are packed in declaration
    order into as few RGBA attachments as fit, so a smaller layout is also fewer targets to write.
    """
    with_color: bool = False
    dtype: str = "f4"
    omit: frozenset[str] = frozenset()
    with_emission: bool = False  # the optional emission channel (scenes with emissive surfaces)
    # the optional dielectric channel (scenes with KHR_materials_ior / _specular materials)
    with_dielectric: bool = False
    with_clearcoat: bool = False  # the optional clearcoat channel (KHR_materials_clearcoat)
    # the optional transmission channels (KHR_materials_transmission / _volume)
    with_transmission: bool = False
    with_sheen: bool = False  # the optional sheen channel (KHR_materials_sheen)
    with_anisotropy: bool = False  # the optional anisotropy channel (KHR_materials_anisotropy)
    with_iridescence: bool = False  # the optional iridescence channel (KHR_materials_iridescence)
    with_dispersion: bool = False  # the optional dispersion channel (KHR_materials_dispersion)

    def __post_init__(self):
        unknown = set(self.omit) - set(CHANNEL_NAMES)
        if unknown or {"alpha"} & set(self.omit):
            raise ValueError(f"cannot omit G-buffer channels {sorted(unknown | ({'alpha'} & set(self.omit)))}")

    @property
    def channels(self) -> tuple[Channel, ...]:
        """The allocated channels, with this layout's attachment and offset for each."""
        return _pack(tuple(c for c in CHANNELS
                           if self._wanted_optional(c) and c.name not in self.omit))

    def _wanted_optional(self, c: Channel) -> bool:
        return not c.optional or {"color": self.with_color, "emission": self.with_emission,
                                  "dielectric": self.with_dielectric,
                                  "clearcoat": self.with_clearcoat,
                                  "transmission": self.with_transmission,
                                  "transmission_ior": self.with_transmission,
                                  "sheen": self.with_sheen,
                                  "anisotropy": self.with_anisotropy,
                                  "iridescence": self.with_iridescence,
                                  "dispersion": self.with_dispersion}[c.name]

    def check_draw_buffers(self) -> None:
        """A SceneError naming the optional channels when this layout needs more attachments than
        GL guarantees draw buffers (:data:`MAX_ATTACHMENTS`): a scene whose materials use every
        extension at once. (Torch-side layouts, which allocate nothing, may list every channel.)"""
        if len(self.attachments) > MAX_ATTACHMENTS:
            lobes = [c.name for c in self.channels if c.optional]
            raise SceneError(f"the scene's materials need {len(self.attachments)} G-buffer "
                             f"attachments ({', '.join(lobes)} besides the base), more than "
                             f"GL's guaranteed {MAX_ATTACHMENTS}; drop one of these extensions "
                             f"from the materials")

    def bytes_per_pixel(self) -> int:
        """Render-target memory of this layout per pixel: RGBA attachments of 4 (``f4``) or 2
        (``f2``) bytes per component."""
        return len(self.attachments) * 4 * (4 if self.dtype == "f4" else 2)

    @property
    def attachments(self) -> tuple[int, ...]:
        return tuple(sorted({c.attachment for c in self.channels}))

    def channel(self, name: str) -> Channel:
        """A channel of this layout (with its slot), or the declaration of an omitted one."""
        for c in self.channels:
            if c.name == name:
                return c
        for c in CHANNELS:
            if c.name == name:
                return c
        raise KeyError(name)

    # ---- GLSL -------------------------------------------------------------------------------
    def glsl(self, load_name: str = "gbuffer_load") -> str:
        """The generated ``generated/gbuffer.glsl``: struct, defaults, store and load functions.

        ``#define GBUFFER_WRITE`` before including it declares the fragment outputs and
        ``gbuffer_store``; ``#define GBUFFER_READ`` declares samplers ``u_gbuffer<i>`` and
        ``gbuffer_load(ivec2 pixel)`` (named ``load_name``: the forward pass renames it and puts
        its own ``gbuffer_load`` in its place). Channels not in this layout keep their background
        value.
        """
        lines = ["// generated from viewer/gbuffer.py (GBufferLayout); do not edit",
                 f"#define GBUFFER_HAS_COLOR {int(self.with_color)}",
                 f"#define GBUFFER_HAS_EMISSION {int(self.with_emission)}",
                 f"#define GBUFFER_HAS_DIELECTRIC {int(self.with_dielectric)}",
                 f"#define GBUFFER_HAS_CLEARCOAT {int(self.with_clearcoat)}",
                 f"#define GBUFFER_HAS_TRANSMISSION {int(self.with_transmission)}",
                 f"#define GBUFFER_HAS_SHEEN {int(self.with_sheen)}",
                 "#define GBUFFER_SHEEN(g) " + ("((g).sheen)" if self.with_sheen else "vec4(0.0)"),
                 f"#define GBUFFER_HAS_ANISOTROPY {int(self.with_anisotropy)}",
                 "#define GBUFFER_ANISOTROPY(g) " + ("((g).anisotropy)" if self.with_anisotropy
                                                     else "vec2(0.0)"),
                 f"#define GBUFFER_HAS_IRIDESCENCE {int(self.with_iridescence)}",
                 f"#define GBUFFER_HAS_DISPERSION {int(self.with_dispersion)}",
                 "#define GBUFFER_IRIDESCENCE(g) " + ("((g).iridescence)" if self.with_iridescence
                                                      else "vec3(0.0)"),
                 "struct GBuffer {"]
        declared = [c for c in CHANNELS
                    if not c.declared_when_allocated or self._wanted_optional(c)]
        lines += [f"    {_GLSL_TYPE[c.components]} {c.name};" for c in declared]
        lines.append("};")
        lines.append("GBuffer gbuffer_background() {")
        lines.append("    GBuffer g;")
        for c in declared:
            vals = ", ".join(f"{v:.9g}" if "." in f"{v:.9g}" or "e" in f"{v:.9g}" else f"{v:.1f}"
                             for v in c.background)
            lines.append(f"    g.{c.name} = {_GLSL_TYPE[c.components]}({vals});")
        lines.append("    return g;")
        lines.append("}")
        lines.append("#ifdef GBUFFER_WRITE")
        for a in self.attachments:
            lines.append(f"layout(location = {a}) out vec4 o_gbuffer{a};")
        lines.append("void gbuffer_store(GBuffer g) {")
        for a in self.attachments:
            lines.append(f"    o_gbuffer{a} = vec4(0.0);")
        for c in self.channels:
            sw = _SWIZZLE[c.offset:c.offset + c.components]
            lines.append(f"    o_gbuffer{c.attachment}.{sw} = g.{c.name};")
        lines.append("}")
        lines.append("#endif")
        lines.append("#ifdef GBUFFER_READ")
        for a in self.attachments:
            lines.append(f"uniform sampler2D u_gbuffer{a};")
        lines.append(f"GBuffer {load_name}(ivec2 pixel) {{")
        lines.append("    GBuffer g = gbuffer_background();")
        for a in self.attachments:
            lines.append(f"    vec4 t{a} = texelFetch(u_gbuffer{a}, pixel, 0);")
        for c in self.channels:
            sw = _SWIZZLE[c.offset:c.offset + c.components]
            lines.append(f"    g.{c.name} = t{c.attachment}.{sw};")
        lines.append("    return g;")
        lines.append("}")
        lines.append("#endif")
        return "\n".join(lines) + "\n"

    def virtual_files(self) -> dict[str, str]:
        """For :func:`viewer.gl.programs.assemble`: ``#include "generated/gbuffer.glsl"``."""
        return {"generated/gbuffer.glsl": self.glsl()}

    # ---- numpy ------------------------------------------------------------------------------
    def background(self, height: int, width: int) -> dict[str, np.ndarray]:
        """Channel dict filled with background values, each ``[H, W, C]`` float32."""
        return {c.name: np.broadcast_to(np.asarray(c.background, np.float32),
                                        (height, width, c.components)).copy()
                for c in self.channels}

    def pack(self, channels: dict[str, np.ndarray]) -> dict[int, np.ndarray]:
        """Channel dict (``[H, W, C]`` each; missing ones take background values) -> attachment
        index -> ``[H, W, 4]`` float32 arrays, ready to upload."""
        first = next(iter(channels.values()))
        h, w = first.shape[:2]
        full = self.background(h, w)
        kept = {c.name for c in self.channels}
        for name, arr in channels.items():
            if name not in kept:
                continue
            c = self.channel(name)
            arr = np.asarray(arr, np.float32).reshape(h, w, -1)
            if arr.shape[2] != c.components:
                raise ValueError(f"channel {name} has {arr.shape[2]} components, "
                                 f"expected {c.components}")
            full[name] = arr
        if "color" not in channels and self.with_color:
            # surfaces without a baked colour show their albedo unlit (premultiplied)
            full["color"] = full["albedo"] * full["alpha"]
        out = {a: np.zeros((h, w, 4), np.float32) for a in self.attachments}
        for c in self.channels:
            out[c.attachment][:, :, c.offset:c.offset + c.components] = full[c.name]
        return out

    def unpack(self, attachments: dict[int, np.ndarray]) -> dict[str, np.ndarray]:
        """Attachment index -> ``[H, W, 4]`` arrays back to the channel dict."""
        return {c.name: attachments[c.attachment][:, :, c.offset:c.offset + c.components].copy()
                for c in self.channels}
