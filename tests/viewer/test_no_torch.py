"""The runtime never imports torch: rendering, the viewer's modules and the CLI run without it."""
import subprocess
import sys


def test_viewer_runtime_does_not_import_torch(tmp_path):
    code = (
        "import sys\n"
        "import viewer, viewer.renderer, relight.cli, viewer.neural, viewer.specialize\n"
        "import relight.app.state, viewer.splats, relight.bench.run\n"
        "from viewer.renderer import Renderer\n"
        "from viewer.scene.description import scene_from_dict\n"
        "r = Renderer()\n"
        "for model in ('unlit', 'ggx_split_sum', 'ggx_mc', 'neural'):\n"
        "    r.render(scene_from_dict({'camera': {'size': [16, 16]}, 'objects': [{'type': 'sphere'}],\n"
        "                              'render': {'model': model, 'samples': 2}}))\n"
        "assert 'torch' not in sys.modules, 'torch was imported'\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().endswith("ok")
