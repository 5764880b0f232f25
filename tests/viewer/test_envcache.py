"""viewer.environment.disk_cache: the on-disk cache of environment precomputation. A hit rebuilds the same
textures without decoding the file; corrupt, truncated, stale or ill-fitting entries are rebuilt
with a one-line warning naming the file; the folder stays within its cap (LRU by mtime); the
environment variables choose, size or turn off the cache."""
import os
import time

import numpy as np
import pytest

import viewer.environment.store as environments
from viewer.environment import disk_cache as envcache
from viewer.environment.disk_cache import EnvCache, cache_root
from viewer.environment.ibl import IBLOptions
from viewer.environment.maps import EnvironmentSpec, sky_environment
from viewer.environment.store import EnvironmentStore
from viewer.imageio import write_exr

OPTS = IBLOptions(prefilter_width=128, dfg_size=16, dfg_samples=64)


@pytest.fixture
def sky_file(tmp_path):
    path = tmp_path / "sky.exr"
    write_exr(path, sky_environment(128))
    return path


def _snapshot(store, spec):
    plain, sunless = store.ibl(spec), store.ibl(spec, sun=True)
    out = {f"{n}{k}": ibl.read_level("prefiltered", k)
           for n, ibl in (("plain", plain), ("sunless", sunless)) for k in range(plain.levels)}
    out["radiance"] = plain.read_level("radiance", 0)
    out["sh"], out["sh_sunless"] = plain.sh, sunless.sh
    out["irradiance"] = plain.read_level("irradiance")
    out["irradiance_sunless"] = sunless.read_level("irradiance")
    out["dirs"] = store.power_directions(spec)
    out["sampling"] = store.env_sampling(spec).read()["conditional"]
    out["dfg"] = plain.read_level("dfg")
    return out, store.lights(spec)


def _build(programs, disk, spec):
    s = EnvironmentStore(programs, options=OPTS, disk=disk)
    try:
        return _snapshot(s, spec)
    finally:
        s.release()


def test_hit_rebuilds_the_same_without_decoding(programs, tmp_path, sky_file, monkeypatch):
    disk = EnvCache(tmp_path / "cache")
    spec = EnvironmentSpec(path=str(sky_file))
    first, sun = _build(programs, disk, spec)
    assert disk.writes == 4 and {p.name.split(".")[1] for p in disk.root.iterdir()} == {
        "ibl", "dfg", "sampling", "directions"}

    def no_decoding(spec):
        raise AssertionError("the file was decoded on a cache hit")

    monkeypatch.setattr(environments, "load_environment", no_decoding)
    again = EnvCache(tmp_path / "cache")
    second, sun2 = _build(programs, again, spec)
    assert again.hits == 4 and again.misses == 0 and sun2 == sun
    for name, arr in first.items():
        np.testing.assert_array_equal(second[name], arr, err_msg=name)


def _flip_bytes(path, at):
    data = bytearray(path.read_bytes())
    data[at] ^= 0xFF
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("damage", ["corrupt", "truncated", "stale", "shape"])
def test_bad_entry_is_rebuilt_with_a_warning(programs, tmp_path, sky_file, damage, monkeypatch):
    disk = EnvCache(tmp_path / "cache")
    spec = EnvironmentSpec(path=str(sky_file))
    first, _ = _build(programs, disk, spec)
    entry = next(disk.root.glob("*.ibl.safetensors"))
    if damage == "corrupt":  # a bit flip in the arrays: the checksum catches it
        _flip_bytes(entry, entry.stat().st_size - 100)
        reason = "checksum mismatch"
    elif damage == "truncated":
        entry.write_bytes(entry.read_bytes()[: entry.stat().st_size // 2])
        reason = "unreadable or truncated"
    elif damage == "stale":  # written by another format version
        key = entry.name.split(".")[0]
        arrays, meta = disk.load(key, "ibl")
        monkeypatch.setattr(envcache, "FORMAT", envcache.FORMAT + 1)
        disk.save(key, "ibl", arrays, meta)
        monkeypatch.setattr(envcache, "FORMAT", envcache.FORMAT - 1)
        reason = "stale"
    else:  # valid file, arrays that do not fit the options' chain
        key = entry.name.split(".")[0]
        arrays, meta = disk.load(key, "ibl")
        arrays["level1"] = arrays["level1"][:, :-1]
        disk.save(key, "ibl", arrays, meta)
        reason = "does not fit"
    again = EnvCache(tmp_path / "cache")
    with pytest.warns(UserWarning, match=rf"{entry.name}: environment cache entry {reason}"):
        second, _ = _build(programs, again, spec)
    assert again.rejected == 1
    for name, arr in first.items():
        np.testing.assert_array_equal(second[name], arr, err_msg=name)
    # rebuilt and written again: the next store hits
    third = EnvCache(tmp_path / "cache")
    _build(programs, third, spec)
    assert third.rejected == 0 and third.hits == 4


def test_load_warnings_are_kept_for_a_hit(programs, tmp_path):
    """A file's loading warning (NaN texels set to 0) is shown on a hit too."""
    env = sky_environment(64)
    env[3, 4, 1] = np.nan
    path = tmp_path / "nan.exr"
    write_exr(path, env)
    spec = EnvironmentSpec(path=str(path))
    for _ in range(2):
        disk = EnvCache(tmp_path / "cache")
        with pytest.warns(UserWarning, match="1 negative, NaN or Inf texel values set to 0"):
            _build(programs, disk, spec)
    assert disk.hits == 4


def test_cap_is_respected_lru(tmp_path):
    cache = EnvCache(tmp_path / "c", max_bytes=10_000)
    blob = {"a": np.zeros(600, np.float32)}  # ~2.5 KB a file
    for i, key in enumerate(("k1", "k2", "k3")):
        cache.save(key, "ibl", blob, {})
        os.utime(cache.path(key, "ibl"), (1000 + i, 1000 + i))
    cache.load("k1", "ibl")  # most recently used now
    for key in ("k4", "k5"):
        cache.save(key, "ibl", blob, {})
        time.sleep(0.01)
    assert cache.bytes <= 10_000
    kept = {p.name.split(".")[0] for p in cache.root.iterdir()}
    assert "k1" in kept and "k2" not in kept and "k5" in kept
    tiny = EnvCache(tmp_path / "t", max_bytes=100)
    tiny.save("big", "ibl", blob, {})
    assert tiny.bytes == 0  # an entry larger than the cap is not kept


def test_environment_variables(tmp_path, monkeypatch):
    monkeypatch.delenv("RELIGHT_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_root() == tmp_path / "xdg" / "relight"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache_root() == envcache.Path.home() / ".cache" / "relight"
    monkeypatch.setenv("RELIGHT_CACHE_DIR", str(tmp_path / "mine"))
    monkeypatch.setenv("RELIGHT_ENV_CACHE", "1")
    monkeypatch.setenv("RELIGHT_ENV_CACHE_MB", "3")
    c = EnvCache.from_environment()
    assert c.root == tmp_path / "mine" / "environments" and c.max_bytes == 3 << 20
    monkeypatch.setenv("RELIGHT_ENV_CACHE_MB", "lots")
    with pytest.raises(ValueError, match="RELIGHT_ENV_CACHE_MB"):
        EnvCache.from_environment()
    for off in ("0", "off", "false"):
        monkeypatch.setenv("RELIGHT_ENV_CACHE", off)
        assert EnvCache.from_environment() is None


def test_store_uses_the_users_cache_unless_turned_off(programs, tmp_path, monkeypatch):
    monkeypatch.setenv("RELIGHT_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("RELIGHT_ENV_CACHE", "1")
    s = EnvironmentStore(programs, options=OPTS)
    try:
        assert s.disk is not None and s.disk.root == tmp_path / "environments"
        s.ibl(EnvironmentSpec(procedural="studio", width=64))
        assert any((tmp_path / "environments").glob("*.ibl.safetensors"))
    finally:
        s.release()
    monkeypatch.setenv("RELIGHT_ENV_CACHE", "0")
    assert EnvironmentStore(programs, options=OPTS).disk is None
    legacy = EnvironmentStore(programs, options=IBLOptions.legacy())
    assert legacy.disk is None  # the method before had no disk cache
