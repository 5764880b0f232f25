"""A glTF material whose texture image is missing or cannot be decoded loads without that map and
one warning names the glTF file, the image and what is done (three.js warns and renders the same);
a corrupt buffer stays an error naming the file."""
import numpy as np
import pytest
from PIL import Image

from gltf_builder import RED, GltfBuilder, color_at, image, load_warnings, quad
from viewer.errors import InputError
from viewer.geometry.loaders import load_mesh


def _quad_with_image_file(tmp_path, image_bytes: bytes | None, name="albedo.png"):
    """A quad whose base-colour texture is the file ``name`` (written only when ``image_bytes``);
    base colour factor (0.2, 0.4, 0.6)."""
    b = GltfBuilder()
    tex = b.image(image([[RED]]))
    b.doc["images"][-1]["uri"] = name
    m = b.material(pbrMetallicRoughness={"baseColorTexture": {"index": tex},
                                         "baseColorFactor": [0.2, 0.4, 0.6, 1.0],
                                         "metallicFactor": 0.0},
                   doubleSided=True)
    quad(b, m)
    if image_bytes is not None:
        (tmp_path / name).write_bytes(image_bytes)
    return b.save(tmp_path / "scene.gltf")


def _png(rgba) -> bytes:
    import io

    buf = io.BytesIO()
    Image.fromarray(image([[rgba]])).save(buf, format="PNG")
    return buf.getvalue()


@pytest.mark.parametrize("case", ["missing", "undecodable"])
def test_missing_or_undecodable_image_warns_and_loads_without_the_map(tmp_path, gbuffer_of, case):
    path = _quad_with_image_file(tmp_path, None if case == "missing" else b"not a png at all")
    meshes, messages = load_warnings(path)
    about = [m for m in messages if "albedo.png" in m]
    assert len(about) == 1, messages
    assert str(path) in about[0] and "rendered without its base-colour map" in about[0]
    assert "\n" not in about[0]
    (mesh,) = list(meshes)
    assert "base_color" not in mesh.textures and "base_color" not in mesh.sampling
    assert mesh.material.albedo == pytest.approx((0.2, 0.4, 0.6))  # the factors stay
    g = gbuffer_of(list(meshes))
    np.testing.assert_allclose(color_at(g, 0.0, 0.0), [0.2, 0.4, 0.6], atol=2e-3)


def test_present_image_still_loads_its_texture(tmp_path, gbuffer_of):
    path = _quad_with_image_file(tmp_path, _png((255, 255, 255, 255)))
    meshes, messages = load_warnings(path)
    assert not [m for m in messages if "albedo.png" in m], messages
    (mesh,) = list(meshes)
    assert mesh.textures["base_color"].shape[:2] == (1, 1)
    g = gbuffer_of(list(meshes))
    np.testing.assert_allclose(color_at(g, 0.0, 0.0), [0.2, 0.4, 0.6], atol=2e-3)  # white * factor


def test_a_truncated_buffer_stays_an_error(tmp_path):
    b = GltfBuilder()
    quad(b)
    path = b.save(tmp_path / "cut.gltf")
    text = path.read_text()
    import json

    doc = json.loads(text)
    doc["buffers"][0]["byteLength"] += 1000  # the data URI holds fewer bytes than declared
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="cut.gltf"):
        load_mesh(path)
