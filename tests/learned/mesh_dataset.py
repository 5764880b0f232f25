"""The tiny rasteriser-target split with meshes of the mesh and splat geometry tests
(test_mesh_geometry.py, test_splat_geometry.py; the session fixture ``mesh_dataset``): one val
sample per kind of MESH_KINDS (a glTF scene, a concave mesh on a floor, a sphere on a floor), 32
px, with its _meshes folder."""
from dataclasses import replace

MESH_KINDS = ("gltf", "concave", "sphere_on_plane")


def make_mesh_dataset(root, ctx):
    from learned.data.generator import generate
    from learned.protocol.data import protocol_configs
    from viewer.renderer import Renderer

    config = replace(protocol_configs({"val": len(MESH_KINDS)}, size=32, targets="rasteriser",
                                      seed=5)["val"], samples=4, env_width=32,
                     scene_kinds=MESH_KINDS)
    r = Renderer(ctx=ctx)
    try:
        generate(root, config, renderer=r, progress=False)
    finally:
        r.release()
    return root
