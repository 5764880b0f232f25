"""Fixtures of the viewer tests: ``gbuffer_of``, a glTF file (or meshes) drawn into a G-buffer by
the test camera of gltf_builder.py."""
import pytest


@pytest.fixture
def gbuffer_of(ctx, programs):
    """``gbuffer_of(path)``: load a glTF and draw it from (0, 0, 3) towards the origin, 64x64;
    returns the channels, row 0 at the top."""
    from gltf_builder import SIZE

    from viewer.gbuffer import GBufferLayout
    from viewer.geometry.loaders import load_mesh
    from viewer.passes.gbuffer import GBufferPass, GBufferTargets
    from viewer.scene.camera import Camera

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
