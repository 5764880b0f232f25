"""The environment disk cache is keyed by content: a hit for a copy of a file under another name
replays the first load's warnings naming the path passed this time, not the first one's."""
import shutil
import warnings

import numpy as np

from viewer.environment.disk_cache import EnvCache
from viewer.environment.ibl import IBLOptions
from viewer.environment.maps import EnvironmentSpec, sky_environment
from viewer.environment.store import EnvironmentStore
from viewer.imageio import write_exr

OPTS = IBLOptions(prefilter_width=128, dfg_size=16, dfg_samples=64)


def _load(programs, disk, path) -> list[str]:
    """The warnings of building the IBL of ``path`` in a fresh store."""
    store = EnvironmentStore(programs, options=OPTS, disk=disk)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            store.ibl(EnvironmentSpec(path=str(path)))
    finally:
        store.release()
    return [str(w.message) for w in caught]


def test_a_hit_for_a_copy_names_the_copy(programs, tmp_path):
    env = sky_environment(64)
    env[3, 4, 1] = np.nan  # the loader warns: "<path>: 1 negative, NaN or Inf texel values ..."
    first, second = tmp_path / "a" / "first.exr", tmp_path / "b" / "second.exr"
    first.parent.mkdir()
    second.parent.mkdir()
    write_exr(first, env)
    shutil.copyfile(first, second)
    disk = EnvCache(tmp_path / "cache")
    notes = [m for m in _load(programs, disk, first) if "NaN" in m]
    assert len(notes) == 1 and notes[0].startswith(f"{first}: ")
    disk = EnvCache(tmp_path / "cache")
    notes = [m for m in _load(programs, disk, second) if "NaN" in m]
    assert disk.hits >= 1 and disk.writes == 0  # the same content: read from the cache
    assert len(notes) == 1 and notes[0].startswith(f"{second}: "), notes
    assert "first.exr" not in notes[0]
    # and the first file, loaded again, still names itself
    notes = [m for m in _load(programs, EnvCache(tmp_path / "cache"), first) if "NaN" in m]
    assert len(notes) == 1 and notes[0].startswith(f"{first}: "), notes
