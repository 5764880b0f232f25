"""Mesh loaders: glTF (written by pygltflib and by trimesh), OBJ+MTL, and every bad-file path."""
import io

import numpy as np
import pygltflib
import pytest

from viewer.errors import InputError
from viewer.geometry.loaders import load_mesh
from viewer.geometry.mesh import srgb_to_linear
from viewer.scene.material import Material


def _png_bytes(rgb_u8: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgb_u8).save(buf, format="PNG")
    return buf.getvalue()


def _write_glb(path, with_textures=True, with_tangents=True, translation=(0.0, 0.0, 0.0)):
    """A unit quad in the z = 0 plane facing +Z, uv (0, 0) at the top left."""
    pos = np.float32([[-1, 1, 0], [-1, -1, 0], [1, -1, 0], [1, 1, 0]])
    nrm = np.tile(np.float32([0, 0, 1]), (4, 1))
    uv = np.float32([[0, 0], [0, 1], [1, 1], [1, 0]])
    tan = np.tile(np.float32([1, 0, 0, 1]), (4, 1))
    idx = np.uint32([0, 1, 2, 0, 2, 3])
    arrays = [(pos, "VEC3"), (nrm, "VEC3"), (uv, "VEC2")]
    if with_tangents:
        arrays.append((tan, "VEC4"))
    blob = b""
    views, accessors = [], []
    for arr, kind in arrays:
        views.append(pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=arr.nbytes,
                                          target=pygltflib.ARRAY_BUFFER))
        accessors.append(pygltflib.Accessor(bufferView=len(views) - 1, componentType=5126,
                                            count=len(arr), type=kind,
                                            min=arr.min(0).tolist(), max=arr.max(0).tolist()))
        blob += arr.tobytes()
    views.append(pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=idx.nbytes,
                                      target=pygltflib.ELEMENT_ARRAY_BUFFER))
    accessors.append(pygltflib.Accessor(bufferView=len(views) - 1, componentType=5125,
                                        count=len(idx), type="SCALAR"))
    blob += idx.tobytes()
    attrs = pygltflib.Attributes(POSITION=0, NORMAL=1, TEXCOORD_0=2,
                                 TANGENT=3 if with_tangents else None)
    images, textures = [], []
    pbr = pygltflib.PbrMetallicRoughness(baseColorFactor=[0.5, 1.0, 1.0, 1.0], metallicFactor=0.25,
                                         roughnessFactor=0.75)
    material = pygltflib.Material(pbrMetallicRoughness=pbr)
    if with_textures:
        color = np.zeros((2, 2, 3), np.uint8)
        color[0, 0] = (255, 0, 0)  # top left red
        color[1, 1] = (0, 0, 255)
        color[0, 1] = color[1, 0] = (128, 128, 128)
        normal = np.full((2, 2, 3), (128, 128, 255), np.uint8)
        for img in (color, normal):
            data = _png_bytes(img)
            while len(blob) % 4:
                blob += b"\0"
            views.append(pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data)))
            images.append(pygltflib.Image(bufferView=len(views) - 1, mimeType="image/png"))
            textures.append(pygltflib.Texture(source=len(images) - 1))
            blob += data
        pbr.baseColorTexture = pygltflib.TextureInfo(index=0)
        material.normalTexture = pygltflib.NormalMaterialTexture(index=1, scale=0.5)
    gltf = pygltflib.GLTF2(
        scene=0, scenes=[pygltflib.Scene(nodes=[0])],
        nodes=[pygltflib.Node(mesh=0, translation=list(translation))],
        meshes=[pygltflib.Mesh(name="quad", primitives=[
            pygltflib.Primitive(attributes=attrs, indices=len(accessors) - 1, material=0)])],
        materials=[material], accessors=accessors, bufferViews=views,
        buffers=[pygltflib.Buffer(byteLength=len(blob))], images=images, textures=textures)
    gltf.set_binary_blob(blob)
    gltf.save_binary(str(path))
    return path


def test_gltf_with_textures_and_tangents(tmp_path):
    path = _write_glb(tmp_path / "quad.glb", translation=(0.0, 2.0, -1.0))
    (mesh,) = load_mesh(path)
    assert mesh.triangle_count == 2 and mesh.name == "quad"
    np.testing.assert_allclose(mesh.positions.mean(axis=0), [0, 2, -1], atol=1e-6)
    np.testing.assert_allclose(mesh.normals, np.tile([0, 0, 1], (4, 1)))
    np.testing.assert_allclose(mesh.tangents, np.tile([1, 0, 0, 1], (4, 1)))
    assert mesh.material == Material(albedo=(0.5, 1.0, 1.0), roughness=0.75, metallic=0.25)
    assert set(mesh.textures) == {"base_color", "normal"}
    base = mesh.textures["base_color"]
    np.testing.assert_allclose(base[0, 0], [1, 0, 0], atol=1e-6)  # row 0 = image top
    np.testing.assert_allclose(base[0, 1], srgb_to_linear(np.float32([128 / 255] * 3)), atol=1e-6)
    np.testing.assert_allclose(mesh.textures["normal"][0, 0], [128 / 255, 128 / 255, 1], atol=1e-6)
    assert mesh.normal_scale == 0.5


def test_gltf_transform_and_override(tmp_path):
    path = _write_glb(tmp_path / "quad.glb", with_tangents=False)
    t = np.eye(4)
    t[:3, 3] = (5, 0, 0)
    (mesh,) = load_mesh(path, transform=t, material_override=Material(albedo=(0.1, 0.2, 0.3)))
    assert mesh.tangents is None
    np.testing.assert_allclose(mesh.positions.mean(axis=0), [5, 0, 0], atol=1e-6)
    assert mesh.material.albedo == (0.1, 0.2, 0.3)
    assert set(mesh.textures) == {"normal"}  # the override drops material maps, keeps shape


def test_trimesh_exported_gltf(tmp_path):
    import trimesh

    path = tmp_path / "box.glb"
    trimesh.creation.box(extents=(1, 2, 3)).export(str(path))
    meshes = load_mesh(path)
    assert sum(m.triangle_count for m in meshes) == 12
    lo = np.min([m.bounds()[0] for m in meshes], axis=0)
    np.testing.assert_allclose(lo, [-0.5, -1, -1.5], atol=1e-6)
    for m in meshes:
        np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1, atol=1e-5)


def test_obj_with_mtl_gets_smooth_normals(tmp_path):
    (tmp_path / "tri.mtl").write_text("newmtl red\nKd 0.8 0.2 0.1\nNs 100\n")
    (tmp_path / "tri.obj").write_text(
        "mtllib tri.mtl\nusemtl red\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 -1\n"
        "f 1 2 3\nf 1 3 4\nf 1 5 4\n")
    meshes = load_mesh(tmp_path / "tri.obj")
    assert sum(m.triangle_count for m in meshes) == 3
    (mesh,) = meshes
    np.testing.assert_allclose(mesh.material.albedo, (0.8, 0.2, 0.1), atol=1 / 255)
    assert mesh.material.metallic == 0.0
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1, atol=1e-5)
    # Vertex 0 is shared by the z = 0 quad and the x = 0 triangle: its normal is in between.
    n0 = mesh.normals[np.argmin(np.linalg.norm(mesh.positions, axis=1))]
    assert n0[0] > 0.1 and n0[2] > 0.1


@pytest.mark.parametrize("case", ["missing", "truncated_glb", "corrupt_gltf", "unsupported",
                                  "empty_obj", "garbage_glb", "bad_obj_index"])
def test_bad_files_raise_input_error_naming_the_file(tmp_path, case):
    if case == "missing":
        path = tmp_path / "nothere.glb"
    elif case == "truncated_glb":
        full = _write_glb(tmp_path / "full.glb").read_bytes()
        path = tmp_path / "cut.glb"
        path.write_bytes(full[: len(full) // 2])
    elif case == "corrupt_gltf":
        path = tmp_path / "bad.gltf"
        path.write_text('{"asset": {"version": "2.0"}, "meshes": [')
    elif case == "unsupported":
        path = tmp_path / "model.fbx"
        path.write_bytes(b"Kaydara FBX Binary")
    elif case == "empty_obj":
        path = tmp_path / "empty.obj"
        path.write_text("# nothing here\n")
    elif case == "garbage_glb":
        path = tmp_path / "noise.glb"
        path.write_bytes(np.random.default_rng(0).bytes(300))
    else:
        path = tmp_path / "badindex.obj"
        path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n")
    with pytest.raises(InputError) as info:
        load_mesh(path)
    message = str(info.value)
    assert path.name in message and "\n" not in message
