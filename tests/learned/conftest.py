"""Fixtures shared by the learned tests, session-scoped (the tests that use one share it, as when
they were one module): the tiny synthetic ``dataset`` (tiny_dataset.py) of the data, training and
evaluation tests, and the weights files of the neural-shader tests (test_neural*.py): a random
student and teacher (``weights``), a smaller student (``small_weights``), a ``dfg`` student and a
``pbr3`` student; the tiny rasteriser-target split with meshes (``mesh_dataset``) of the mesh and
splat geometry tests."""
import pytest


@pytest.fixture(scope="session")
def mesh_dataset(tmp_path_factory, ctx):
    """mesh_dataset.py's split, made once."""
    from mesh_dataset import make_mesh_dataset

    return make_mesh_dataset(tmp_path_factory.mktemp("meshes") / "d", ctx)


@pytest.fixture(scope="session")
def weights(tmp_path_factory):
    import torch

    from learned.export import export
    from learned.neural.student import Student
    from learned.neural.teacher import Teacher

    d = tmp_path_factory.mktemp("weights")
    torch.manual_seed(1)
    s = Student(hidden=(16, 32), num_freqs=2)
    t = Teacher(hidden=16, num_freqs=1)
    with torch.no_grad():  # move outputs away from the sigmoid's flat ends
        s.layers[-1].weight.mul_(3.0)
    export(s, d / "s.safetensors", {"note": "test"})
    export(t, d / "t.safetensors")
    return d / "s.safetensors", d / "t.safetensors"


@pytest.fixture(scope="session")
def small_weights(tmp_path_factory):
    """A student smaller than ``weights``' (8-12 hidden, one frequency) for the lighting pass in
    every weight storage (test_neural.py: the uniform-block pass compiles 9x faster)."""
    from neural_weights import student_file

    return student_file(tmp_path_factory, "small", 1)


@pytest.fixture(scope="session")
def dfg_weights(tmp_path_factory):
    from neural_weights import student_file

    return student_file(tmp_path_factory, "dfg", 2, features="dfg")


@pytest.fixture(scope="session")
def pbr_weights(tmp_path_factory):
    from neural_weights import student_file

    return student_file(tmp_path_factory, "pbr", 3, features="dfg", output="pbr3")


@pytest.fixture(scope="session")
def dataset(tmp_path_factory, ctx):
    from tiny_dataset import TINY

    from learned.data.generator import generate
    from viewer.renderer import Renderer

    root = tmp_path_factory.mktemp("data") / "d"
    r = Renderer(ctx=ctx)
    try:
        generate(root, TINY, renderer=r, progress=False)
    finally:
        r.release()
    return root
