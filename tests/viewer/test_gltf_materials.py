"""glTF 2.0 materials as the spec defines them: small files built here with pygltflib, one feature
each, asserted numerically (G-buffer values, coverage, radiance) and the warnings for what is not
used."""
import base64
import io
import json
import math
import warnings

import numpy as np
import pygltflib
import pytest

from viewer.camera import Camera
from viewer.gbuffer import GBufferLayout
from viewer.geometry.loaders import load_mesh
from viewer.passes.gbuffer import GBufferPass, GBufferTargets

_COMPONENT = {np.dtype(np.int8): 5120, np.dtype(np.uint8): 5121, np.dtype(np.int16): 5122,
              np.dtype(np.uint16): 5123, np.dtype(np.uint32): 5125, np.dtype(np.float32): 5126}
_TYPE = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}


def png_uri(rgba_u8: np.ndarray) -> str:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgba_u8).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


class GltfBuilder:
    """A glTF document as a dict with one embedded buffer; ``save`` writes it through pygltflib."""

    def __init__(self):
        self.blob = bytearray()
        self.doc = {"asset": {"version": "2.0"}, "buffers": [], "bufferViews": [],
                    "accessors": [], "meshes": [], "nodes": [], "scenes": [{"nodes": []}],
                    "scene": 0, "materials": [], "images": [], "textures": [], "samplers": []}

    def view(self, data: bytes, stride: int | None = None) -> int:
        while len(self.blob) % 4:
            self.blob += b"\0"
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if stride:
            view["byteStride"] = stride
        self.blob += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, arr: np.ndarray, normalized: bool = False, minmax: bool = False,
                 **extra) -> int:
        arr = np.ascontiguousarray(arr)
        nc = 1 if arr.ndim == 1 else arr.shape[1]
        acc = {"componentType": _COMPONENT[arr.dtype], "count": len(arr), "type": _TYPE[nc]}
        if arr.size:
            acc["bufferView"] = self.view(arr.tobytes())
        if normalized:
            acc["normalized"] = True
        if minmax:
            acc["min"] = arr.reshape(len(arr), -1).min(0).tolist()
            acc["max"] = arr.reshape(len(arr), -1).max(0).tolist()
        acc.update(extra)
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def image(self, rgba_u8: np.ndarray, sampler: dict | None = None) -> int:
        """A texture of the PNG image; returns the texture index."""
        self.doc["images"].append({"uri": png_uri(rgba_u8)})
        tex = {"source": len(self.doc["images"]) - 1}
        if sampler is not None:
            self.doc["samplers"].append(sampler)
            tex["sampler"] = len(self.doc["samplers"]) - 1
        self.doc["textures"].append(tex)
        return len(self.doc["textures"]) - 1

    def material(self, **m) -> int:
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def mesh(self, attributes: dict, indices: int | None, material: int | None = None,
             node: dict | None = None, **prim) -> int:
        p = {"attributes": attributes, **prim}
        if indices is not None:
            p["indices"] = indices
        if material is not None:
            p["material"] = material
        self.doc["meshes"].append({"primitives": [p]})
        self.doc["nodes"].append({"mesh": len(self.doc["meshes"]) - 1, **(node or {})})
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)
        return len(self.doc["meshes"]) - 1

    def save(self, path):
        doc = dict(self.doc)
        doc["buffers"] = [{"byteLength": len(self.blob),
                           "uri": "data:application/octet-stream;base64,"
                                  + base64.b64encode(bytes(self.blob)).decode()}]
        doc = {k: v for k, v in doc.items() if v != []}
        gltf = pygltflib.GLTF2.from_json(json.dumps(doc))
        gltf.save(str(path))
        return path


# A unit quad in the z = 0 plane facing +Z; uv (0, 0) at the top left (glTF), u right, v down.
QUAD_POS = np.float32([[-1, 1, 0], [-1, -1, 0], [1, -1, 0], [1, 1, 0]])
QUAD_UV = np.float32([[0, 0], [0, 1], [1, 1], [1, 0]])
QUAD_IDX = np.uint16([0, 1, 2, 0, 2, 3])


def quad(b: GltfBuilder, material: int | None = None, uv=QUAD_UV, extra_attrs=None,
         positions=QUAD_POS, node=None) -> int:
    attrs = {"POSITION": b.accessor(np.asarray(positions, np.float32), minmax=True),
             "NORMAL": b.accessor(np.tile(np.float32([0, 0, 1]), (len(positions), 1)))}
    if uv is not None:
        attrs["TEXCOORD_0"] = b.accessor(np.asarray(uv, np.float32))
    attrs.update(extra_attrs or {})
    return b.mesh(attrs, b.accessor(QUAD_IDX), material, node=node)


def _load_warnings(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        meshes = load_mesh(path)
    return meshes, [str(w.message) for w in caught]


# ---- warnings for everything not used ------------------------------------------------------------
def test_unused_extensions_attributes_and_features_are_named_once(tmp_path):
    b = GltfBuilder()
    m = b.material(pbrMetallicRoughness={"baseColorFactor": [1, 1, 1, 1]},
                   extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 1.0},
                               "KHR_materials_sheen": {}})
    joints = b.accessor(np.zeros((4, 4), np.uint16))
    quad(b, m, extra_attrs={"JOINTS_0": joints, "_TEMPERATURE": b.accessor(np.zeros(4, np.float32))})
    b.doc["extensionsUsed"] = ["KHR_materials_clearcoat", "KHR_materials_sheen",
                               "EXT_mesh_gpu_instancing"]
    b.doc["animations"] = [{"channels": [], "samplers": []}]
    path = b.save(tmp_path / "ignored.gltf")
    (mesh,), messages = _load_warnings(path)
    assert mesh.triangle_count == 2
    assert len(messages) == 1, messages
    (msg,) = messages
    assert "\n" not in msg and str(path) in msg
    for item in ("KHR_materials_clearcoat (changes the BSDF", "KHR_materials_sheen (changes the BSDF",
                 "extension EXT_mesh_gpu_instancing", "attribute JOINTS_0",
                 "attribute _TEMPERATURE", "animations"):
        assert item in msg, (item, msg)


def test_a_plain_file_loads_without_warnings(tmp_path):
    b = GltfBuilder()
    quad(b, b.material(pbrMetallicRoughness={"baseColorFactor": [0.5, 0.5, 0.5, 1]},
                       doubleSided=True))
    _, messages = _load_warnings(b.save(tmp_path / "plain.gltf"))
    assert messages == []


# ---- rendering a file into a G-buffer --------------------------------------------------------
SIZE = 64
TAN = math.tan(math.radians(20.0))  # half the field of view of the test camera


@pytest.fixture
def gbuffer_of(ctx, programs):
    """``gbuffer_of(path)``: load a glTF and draw it from (0, 0, 3) towards the origin, 64x64;
    returns the channels, row 0 at the top."""
    layout = GBufferLayout(with_emission=True)
    targets = GBufferTargets.create(ctx, layout, (SIZE, SIZE))
    gpass = GBufferPass(programs, layout)
    camera = Camera(position=(0.0, 0.0, 3.0), target=(0.0, 0.0, 0.0), fov_y=40.0,
                    size=(SIZE, SIZE))

    def draw(path_or_meshes):
        meshes = (load_mesh(path_or_meshes) if not isinstance(path_or_meshes, list)
                  else path_or_meshes)
        targets.clear()
        gpass.draw_meshes(targets, camera, meshes)
        return targets.read()

    yield draw
    gpass.release()
    targets.release()


def px(x: float, y: float = 0.0) -> tuple[int, int]:
    """(row, column) of the pixel showing the point (x, y, 0) to the test camera."""
    col = (x / (3.0 * TAN) + 1.0) / 2.0 * SIZE
    row = (1.0 - (y / (3.0 * TAN) + 1.0) / 2.0) * SIZE
    return int(row), int(col)


RED, GREEN, BLUE, WHITE = (255, 0, 0, 255), (0, 255, 0, 255), (0, 0, 255, 255), (255,) * 4
NEAREST = {"magFilter": 9728, "minFilter": 9728}


def image(rows) -> np.ndarray:
    return np.asarray(rows, np.uint8)


def color_at(g, x, y):
    return g["albedo"][px(x, y)]


# ---- doubleSided, alphaMode MASK ---------------------------------------------------------------
@pytest.mark.parametrize("double_sided", [False, True])
def test_back_face_absent_when_single_sided_flipped_when_double_sided(tmp_path, gbuffer_of,
                                                                       double_sided):
    b = GltfBuilder()
    m = b.material(pbrMetallicRoughness={"baseColorFactor": [0.5, 0.5, 0.5, 1]},
                   doubleSided=double_sided)
    quad(b, m, node={"rotation": [0.0, 1.0, 0.0, 0.0]})  # 180 degrees about y: faces -z
    quad(b, m, positions=QUAD_POS * 0.25 + np.float32([0.6, 0.6, 0.5]))  # faces the camera
    g = gbuffer_of(b.save(tmp_path / "sides.gltf"))
    assert g["alpha"][px(0.75, 0.75)][0] == 1.0  # the front face, always there
    np.testing.assert_allclose(g["normal"][px(0.75, 0.75)], [0, 0, 1], atol=1e-6)
    back = px(-0.5, -0.5)
    if double_sided:
        assert g["alpha"][back][0] == 1.0
        np.testing.assert_allclose(g["normal"][back], [0, 0, 1], atol=1e-6)  # flipped from -z
    else:
        assert g["alpha"][back][0] == 0.0
        assert (g["alpha"][..., 0] > 0).sum() < 0.1 * SIZE * SIZE  # only the small front quad


def _masked_quad(tmp_path, mode, factor_alpha=1.0, cutoff=None):
    b = GltfBuilder()
    # left column alpha 0.2, right column alpha 0.9
    tex = b.image(image([[(255, 255, 255, 51), (255, 255, 255, 230)]] * 2),
                  sampler={**NEAREST, "wrapS": 33071, "wrapT": 33071})
    m = b.material(pbrMetallicRoughness={"baseColorTexture": {"index": tex},
                                         "baseColorFactor": [1, 1, 1, factor_alpha]},
                   alphaMode=mode, doubleSided=True,
                   **({} if cutoff is None else {"alphaCutoff": cutoff}))
    quad(b, m)
    return b.save(tmp_path / f"mask_{mode}.gltf")


def test_alpha_mask_discards_below_the_cutoff(tmp_path, gbuffer_of):
    quad_pixels = np.zeros((SIZE, SIZE), bool)
    r0, c0 = px(-1, 1)
    r1, c1 = px(1, -1)
    quad_pixels[r0 + 1:r1, c0 + 1:c1] = True
    opaque = gbuffer_of(_masked_quad(tmp_path, "OPAQUE"))["alpha"][..., 0] > 0
    assert opaque[quad_pixels].all()
    masked = gbuffer_of(_masked_quad(tmp_path, "MASK"))["alpha"][..., 0] > 0
    # coverage: the right half of the quad exactly (0.9 >= 0.5 > 0.2)
    assert masked[px(0.5, 0.5)] and masked[px(0.5, -0.5)]
    assert not masked[px(-0.5, 0.5)] and not masked[px(-0.5, -0.5)]
    assert abs(masked.sum() / opaque.sum() - 0.5) < 0.05
    # the factor's alpha multiplies: 0.6 x 0.9 = 0.54 >= 0.5 stays, 0.5 x 0.9 = 0.45 goes
    assert (gbuffer_of(_masked_quad(tmp_path, "MASK", 0.6))["alpha"][..., 0] > 0).sum() \
        == masked.sum()
    assert (gbuffer_of(_masked_quad(tmp_path, "MASK", 0.5))["alpha"][..., 0] > 0).sum() == 0
    # the cutoff is the file's: 0.1 keeps both columns
    assert (gbuffer_of(_masked_quad(tmp_path, "MASK", cutoff=0.1))["alpha"][..., 0] > 0).sum() \
        == opaque.sum()


# ---- samplers, texture coordinate sets, KHR_texture_transform, COLOR_0 ------------------------
def _textured_quad(tmp_path, name, img, sampler=None, info_extra=None, uv=QUAD_UV,
                   extra_attrs=None, **material):
    b = GltfBuilder()
    tex = b.image(img, sampler=sampler)
    info = {"index": tex, **(info_extra or {})}
    m = b.material(pbrMetallicRoughness={"baseColorTexture": info}, doubleSided=True, **material)
    attrs = {k: b.accessor(v) for k, v in (extra_attrs or {}).items()}
    quad(b, m, uv=uv, extra_attrs=attrs)
    return b.save(tmp_path / f"{name}.gltf")


def test_texture_transform_rotates_as_the_spec_example(tmp_path, gbuffer_of):
    # The extension's JSON example: offset [0, 1], rotation pi/2, scale [0.5, 0.5] "utilizes only
    # the lower left quadrant of the source image, rotated clockwise 90 degrees". That quadrant
    # here is [[red, green], [blue, white]] (rows top to bottom); rotated clockwise it reads
    # [[blue, red], [white, green]]. By hand: uv -> (v / 2, 1 - u / 2), so the quad's top right
    # (u ~ 0.75, v ~ 0.25) reads texel (0.125, 0.625) -> column 0, row 2: red.
    k = (0, 0, 0, 255)
    img = image([[k, k, k, k], [k, k, k, k], [RED, GREEN, k, k], [BLUE, WHITE, k, k]])
    transform = {"KHR_texture_transform": {"offset": [0, 1], "rotation": math.pi / 2,
                                           "scale": [0.5, 0.5]}}
    path = _textured_quad(tmp_path, "rotated", img, sampler={**NEAREST, "wrapS": 33071,
                                                              "wrapT": 33071},
                          info_extra={"extensions": transform})
    g = gbuffer_of(path)
    np.testing.assert_allclose(color_at(g, 0.5, 0.5), [1, 0, 0], atol=1e-3)  # top right: red
    np.testing.assert_allclose(color_at(g, 0.5, -0.5), [0, 1, 0], atol=1e-3)  # bottom right
    np.testing.assert_allclose(color_at(g, -0.5, 0.5), [0, 0, 1], atol=1e-3)  # top left: blue
    np.testing.assert_allclose(color_at(g, -0.5, -0.5), [1, 1, 1], atol=1e-3)


@pytest.mark.parametrize("wrap, want", [(10497, "RGRG"), (33648, "RGGR"), (33071, "RGGG")],
                         ids=["repeat", "mirrored_repeat", "clamp_to_edge"])
def test_wrap_modes(tmp_path, gbuffer_of, wrap, want):
    img = image([[RED, GREEN]])
    uv = QUAD_UV * np.float32([2.0, 1.0])  # u from 0 to 2 across the quad
    path = _textured_quad(tmp_path, f"wrap{wrap}", img,
                          sampler={**NEAREST, "wrapS": wrap, "wrapT": 33071}, uv=uv)
    g = gbuffer_of(path)
    colors = {"R": [1, 0, 0], "G": [0, 1, 0]}
    for x, letter in zip((-0.75, -0.25, 0.25, 0.75), want):
        np.testing.assert_allclose(color_at(g, x, 0.0), colors[letter], atol=1e-3,
                                   err_msg=f"u = {x + 1:.2f}")


def test_linear_filter_and_mipmaps_by_sampler(tmp_path, gbuffer_of):
    img = image([[RED, GREEN]])
    nearest = gbuffer_of(_textured_quad(tmp_path, "nearest", img, sampler=NEAREST))
    linear = gbuffer_of(_textured_quad(tmp_path, "linear", img,
                                       sampler={"magFilter": 9729, "minFilter": 9729}))
    centre = px(0.0, 0.0)  # u = 0.5: the boundary of the two texels
    assert set(np.round(nearest["albedo"][centre], 3)) <= {0.0, 1.0}
    np.testing.assert_allclose(linear["albedo"][px(0.02, 0.0)][:2], [0.5, 0.5], atol=0.05)


def test_texcoord_sets_and_the_transform_override(tmp_path, gbuffer_of):
    img = image([[RED, GREEN]])
    uv0 = np.tile(np.float32([0.25, 0.5]), (4, 1))  # the red texel
    uv1 = np.tile(np.float32([0.75, 0.5]), (4, 1))  # the green texel
    for name, info, want in (("set0", {"texCoord": 0}, [1, 0, 0]),
                             ("set1", {"texCoord": 1}, [0, 1, 0]),
                             ("override", {"texCoord": 0, "extensions": {
                                 "KHR_texture_transform": {"texCoord": 1}}}, [0, 1, 0])):
        path = _textured_quad(tmp_path, name, img, sampler=NEAREST, info_extra=info, uv=uv0,
                              extra_attrs={"TEXCOORD_1": uv1})
        np.testing.assert_allclose(color_at(gbuffer_of(path), 0.3, 0.2), want, atol=1e-3,
                                   err_msg=name)


@pytest.mark.parametrize("encoding", ["float", "unorm8", "rgb_unorm16"])
def test_vertex_colour_multiplies_the_base_colour(tmp_path, gbuffer_of, encoding):
    rgba = np.float32([0.4, 0.2, 1.0, 1.0])
    if encoding == "float":
        colors = np.tile(rgba, (4, 1))
    elif encoding == "unorm8":
        colors = np.tile(np.round(rgba * 255).astype(np.uint8), (4, 1))
    else:
        colors = np.tile(np.round(rgba[:3] * 65535).astype(np.uint16), (4, 1))
    b = GltfBuilder()
    m = b.material(pbrMetallicRoughness={"baseColorFactor": [0.5, 1.0, 0.5, 1.0]},
                   doubleSided=True)
    quad(b, m, uv=None, extra_attrs={"COLOR_0": b.accessor(colors,
                                                           normalized=encoding != "float")})
    g = gbuffer_of(b.save(tmp_path / f"color_{encoding}.gltf"))
    np.testing.assert_allclose(color_at(g, 0.1, 0.1), [0.2, 0.2, 0.5], atol=2e-3)


# ---- KHR_mesh_quantization, sparse accessors, Draco -------------------------------------------
def _float_reference(tmp_path):
    b = GltfBuilder()
    quad(b, b.material(doubleSided=True), node={"translation": [0.1, 0.2, 0.0]})
    (mesh,) = load_mesh(b.save(tmp_path / "float.gltf"))
    return mesh


def test_quantised_attributes_give_the_float_positions(tmp_path, gbuffer_of):
    """KHR_mesh_quantization as gltfpack writes it (the quantised Duck): int16 positions rescaled
    by the node, int8 normalised normals, uint16 texture coordinates that the material's
    KHR_texture_transform maps back to [0, 1]."""
    ref = _float_reference(tmp_path)
    b = GltfBuilder()
    img = image([[RED, GREEN], [BLUE, WHITE]])
    tex = b.image(img, sampler=NEAREST)
    scale = 1.0 / 4000.0
    transform = {"KHR_texture_transform": {"scale": [scale, scale]}}
    m = b.material(pbrMetallicRoughness={"baseColorTexture": {"index": tex,
                                                              "extensions": transform}},
                   doubleSided=True)
    pos_q = np.round(QUAD_POS * 1000).astype(np.int16)  # positions x 1000, node scale 1e-3
    nrm_q = np.tile(np.int8([0, 0, 127]), (4, 1))
    uv_q = np.round(QUAD_UV * 4000).astype(np.uint16)
    attrs = {"POSITION": b.accessor(pos_q, minmax=True),
             "NORMAL": b.accessor(nrm_q, normalized=True),
             "TEXCOORD_0": b.accessor(uv_q)}
    b.mesh(attrs, b.accessor(QUAD_IDX), m,
           node={"translation": [0.1, 0.2, 0.0], "scale": [1e-3, 1e-3, 1e-3]})
    b.doc["extensionsUsed"] = ["KHR_mesh_quantization", "KHR_texture_transform"]
    b.doc["extensionsRequired"] = ["KHR_mesh_quantization"]
    path = b.save(tmp_path / "quantised.gltf")
    (mesh,), messages = _load_warnings(path)
    assert messages == []
    np.testing.assert_allclose(mesh.positions, ref.positions, atol=1e-6)
    np.testing.assert_allclose(mesh.normals, ref.normals, atol=1e-6)
    g = gbuffer_of([mesh])
    np.testing.assert_allclose(color_at(g, -0.4, 0.3), [1, 0, 0], atol=1e-3)  # not one colour
    np.testing.assert_allclose(color_at(g, 0.3, -0.4), [1, 1, 1], atol=1e-3)


def test_sparse_accessors(tmp_path):
    ref = _float_reference(tmp_path)
    b = GltfBuilder()
    wrong = QUAD_POS.copy()
    wrong[[1, 3]] = 9.0  # overridden by the sparse block
    which = np.uint16([1, 3])
    values = QUAD_POS[[1, 3]]
    sparse = {"count": 2, "indices": {"bufferView": b.view(which.tobytes()), "componentType": 5123},
              "values": {"bufferView": b.view(values.tobytes())}}
    pos = b.accessor(wrong, minmax=True, sparse=sparse)
    # a sparse accessor without a bufferView: zeros, then the substitutions (all 4 normals)
    nrm_values = np.tile(np.float32([0, 0, 1]), (4, 1))
    nrm = b.accessor(np.zeros((0, 3), np.float32), sparse={
        "count": 4, "indices": {"bufferView": b.view(np.uint8([0, 1, 2, 3]).tobytes()),
                                "componentType": 5121},
        "values": {"bufferView": b.view(nrm_values.tobytes())}})
    b.doc["accessors"][nrm]["count"] = 4
    b.mesh({"POSITION": pos, "NORMAL": nrm}, b.accessor(QUAD_IDX), b.material(doubleSided=True),
           node={"translation": [0.1, 0.2, 0.0]})
    (mesh,) = load_mesh(b.save(tmp_path / "sparse.gltf"))
    np.testing.assert_allclose(mesh.positions, ref.positions, atol=1e-6)
    np.testing.assert_allclose(mesh.normals, ref.normals, atol=1e-6)


def test_draco_compressed_primitive(tmp_path):
    DracoPy = pytest.importorskip("DracoPy", reason="KHR_draco_mesh_compression needs DracoPy")
    ref = _float_reference(tmp_path)
    data = DracoPy.encode(QUAD_POS.astype(np.float64), QUAD_IDX.reshape(-1, 3).astype(np.uint32),
                          quantization_bits=16, preserve_order=True,
                          normals=np.tile([0.0, 0.0, 1.0], (4, 1)))
    decoded = DracoPy.decode(data)
    ids = {a["attribute_type"]: a["unique_id"] for a in decoded.attributes}
    b = GltfBuilder()
    view = b.view(data)
    pos = b.accessor(np.zeros((0, 3), np.float32))
    b.doc["accessors"][pos].update(count=4, min=[-1, -1, 0], max=[1, 1, 0])
    nrm = b.accessor(np.zeros((0, 3), np.float32))
    b.doc["accessors"][nrm]["count"] = 4
    idx = b.accessor(np.zeros(0, np.uint16))
    b.doc["accessors"][idx]["count"] = 6
    b.mesh({"POSITION": pos, "NORMAL": nrm}, idx, b.material(doubleSided=True),
           node={"translation": [0.1, 0.2, 0.0]},
           extensions={"KHR_draco_mesh_compression": {
               "bufferView": view, "attributes": {"POSITION": ids[0], "NORMAL": ids[1]}}})
    b.doc["extensionsUsed"] = ["KHR_draco_mesh_compression"]
    b.doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    (mesh,), messages = _load_warnings(b.save(tmp_path / "draco.gltf"))
    assert messages == []
    # the same triangles (Draco may reorder vertices): compare corner positions per triangle
    got = np.sort(mesh.positions[mesh.indices].reshape(-1, 9), axis=0)
    want = np.sort(ref.positions[ref.indices].reshape(-1, 9), axis=0)
    np.testing.assert_allclose(got, want, atol=1e-4)  # 16-bit quantisation of a 2-unit box
    np.testing.assert_allclose(mesh.normals, np.tile([0, 0, 1], (len(mesh.normals), 1)),
                               atol=1e-3)


# ---- emission -------------------------------------------------------------------------------------
def _emissive_file(tmp_path, strength=None, texture=True):
    b = GltfBuilder()
    m = {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1]}, "doubleSided": True,
         "emissiveFactor": [1.0, 0.5, 0.25]}
    if texture:  # sRGB 255 / 128: linear 1 and 0.2158605
        tex = b.image(image([[(255, 255, 255, 255), (128, 128, 128, 255)]]), sampler=NEAREST)
        m["emissiveTexture"] = {"index": tex}
    if strength is not None:
        m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
        b.doc["extensionsUsed"] = ["KHR_materials_emissive_strength"]
    quad(b, b.material(**m))
    return b.save(tmp_path / "emissive.gltf")


@pytest.mark.parametrize("model", ["unlit", "blinn_phong", "ggx_split_sum", "ggx_mc", "neural"])
def test_emitted_radiance_under_a_black_environment(tmp_path, ctx, model):
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    path = _emissive_file(tmp_path, strength=4.0)
    scene = scene_from_dict({
        "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov_y": 40, "size": [SIZE, SIZE]},
        "environment": {"procedural": "sky", "intensity": 0.0},
        "objects": [{"type": "mesh", "path": str(path)}],
        "render": {"model": model, "samples": 2, "tonemap": "none"}})
    renderer = Renderer(ctx=ctx)
    try:
        frame = renderer.render(scene, aovs=("emission",))
        assert renderer.specialization(scene).layout.with_emission
    finally:
        renderer.release()
    lit = np.float32([1.0, 0.5, 0.25]) * 4.0  # factor x strength
    left, right = frame.radiance[px(-0.5, 0.0)][:3], frame.radiance[px(0.5, 0.0)][:3]
    # unlit shows the albedo too; every lit model reflects nothing of a black environment
    base = np.float32([0.8] * 3) if model == "unlit" else 0.0
    np.testing.assert_allclose(left, base + lit * 1.0, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(right, base + lit * 0.2158605, rtol=1e-3, atol=1e-6)
    np.testing.assert_allclose(frame.aovs["emission"][px(-0.5, 0.0)], lit, rtol=1e-6)
    assert frame.radiance[0, 0, :3].max() == 0.0  # background: the black environment


def test_emission_channel_only_where_a_scene_emits(tmp_path, ctx):
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    b = GltfBuilder()
    quad(b, b.material(doubleSided=True))
    plain = b.save(tmp_path / "plain.gltf")
    renderer = Renderer(ctx=ctx)
    try:
        for path, want in ((plain, False), (_emissive_file(tmp_path, texture=False), True)):
            scene = scene_from_dict({"objects": [{"type": "mesh", "path": str(path)}]})
            assert renderer.specialization(scene).layout.with_emission == want
    finally:
        renderer.release()
