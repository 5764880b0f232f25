"""glTF KHR_materials_variants: the loader picks a variant's materials (a primitive no mapping
names keeps its own), an unknown name is one error line listing the file's variants, scene
files and ``--variant`` on render / scene choose one, and two variants render different
materials."""
import pytest
from gltf_builder import GltfBuilder, load_warnings
from gltf_spheres import RADIUS, grid_scene, uv_sphere


def variants_file(path):
    """One sphere, grey by default; variants "red" and "blue" map it to red / blue materials,
    and "shared" maps nothing (the default stays)."""
    b = GltfBuilder()
    grey, red, blue = (b.material(pbrMetallicRoughness={"baseColorFactor": c + [1.0],
                                                        "metallicFactor": 0.0})
                       for c in ([0.5, 0.5, 0.5], [0.8, 0.1, 0.1], [0.1, 0.1, 0.8]))
    pos, nrm, uv, idx = uv_sphere(12, 24)
    attrs = {"POSITION": b.accessor(pos * RADIUS, minmax=True), "NORMAL": b.accessor(nrm),
             "TEXCOORD_0": b.accessor(uv)}
    b.mesh(attrs, b.accessor(idx), grey, extensions={"KHR_materials_variants": {"mappings": [
        {"material": red, "variants": [0]}, {"material": blue, "variants": [1]}]}})
    b.doc["extensions"] = {"KHR_materials_variants": {"variants": [
        {"name": "red"}, {"name": "blue"}, {"name": "shared"}]}}
    b.doc["extensionsUsed"] = ["KHR_materials_variants"]
    return b.save(path)


def test_variants_pick_their_materials_without_a_warning(tmp_path):
    from viewer.geometry.loaders import load_mesh

    path = variants_file(tmp_path / "v.gltf")
    (mesh,), messages = load_warnings(path)
    assert messages == [] and mesh.material.albedo == (0.5, 0.5, 0.5)
    assert load_mesh(path, variant="red")[0].material.albedo == (0.8, 0.1, 0.1)
    assert load_mesh(path, variant="blue")[0].material.albedo == (0.1, 0.1, 0.8)
    assert load_mesh(path, variant="shared")[0].material.albedo == (0.5, 0.5, 0.5)


def test_an_unknown_variant_is_one_line_listing_the_names(tmp_path):
    from viewer.errors import InputError
    from viewer.geometry.loaders import load_mesh

    path = variants_file(tmp_path / "v.gltf")
    with pytest.raises(InputError) as err:
        load_mesh(path, variant="green")
    text = str(err.value)
    assert "\n" not in text and "v.gltf" in text and "'green'" in text
    assert "its variants are: red, blue, shared" in text
    obj = tmp_path / "t.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(InputError, match="variants are a glTF feature"):
        load_mesh(obj, variant="red")


def test_two_variants_render_different_materials(tmp_path, ctx):
    """The same file under "red" and "blue" (a scene object's ``variant``): the sphere's mean
    colour is red-dominant under one and blue-dominant under the other; the default is grey."""
    from dataclasses import replace

    from viewer.renderer import Renderer

    renderer = Renderer(ctx=ctx)
    scene = grid_scene(variants_file(tmp_path / "v.gltf"), 1).with_render(model="ggx_split_sum")

    def mean(variant):
        s = replace(scene, objects=(replace(scene.objects[0], variant=variant),))
        img = renderer.render(s).radiance
        return img[img[..., 3] > 0.999][:, :3].mean(0)

    red, blue, grey = mean("red"), mean("blue"), mean(None)
    assert red[0] > 2 * red[2] and blue[2] > 2 * blue[0], (red, blue)
    # the default grey (tinted blue by the sky) lies between them, far from either
    assert red[0] / red[2] > 2 * grey[0] / grey[2] > 4 * blue[0] / blue[2], (red, grey, blue)


def test_the_command_line_variant_reaches_the_scene_and_errors_name_the_variants(tmp_path,
                                                                                 capsys):
    from relight.cli import main

    path = variants_file(tmp_path / "v.gltf")
    assert main(["scene", str(path), "--variant", "blue"]) == 0
    out = capsys.readouterr().out
    assert 'variant = "blue"' in out and "--variant blue" in out
    code = main(["render", str(path), "--variant", "green", "--size", "16x16",
                 "--out", str(tmp_path / "x.png")])
    err = capsys.readouterr().err
    assert code != 0 and "its variants are: red, blue, shared" in err
    assert main(["scene", str(path), "--set", "ao=false"]) == 0  # no --variant: no key
    assert "variant = " not in capsys.readouterr().out
    toml = tmp_path / "s.toml"
    toml.write_text(f'[[objects]]\ntype = "mesh"\npath = "{path}"\nvariant = "red"\n')
    from viewer.scene.description import load_scene

    assert load_scene(toml).objects[0].variant == "red"
