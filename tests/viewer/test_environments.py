"""viewer.environment.store.EnvironmentStore: the semantics GPUResources had (IBL, sun-less IBL, sun,
sampling tables, equal-power directions, one entry per environment whatever its intensity and
rotation), a byte bound with LRU eviction that releases GL textures at once, pinning, and the
method before ("fis") still reachable."""
import ctypes
import dataclasses

import numpy as np
import pytest

from viewer.environment.ibl import IBLOptions, build_ibl
from viewer.environment.maps import EnvironmentSpec, load_environment
from viewer.environment.sampling import build_env_sampling, power_directions
from viewer.environment.store import EnvironmentStore
from viewer.environment.sun import extract_sun

OPTS = IBLOptions(prefilter_width=128, dfg_size=16, dfg_samples=64)


def sky(azimuth=30.0, width=128):
    return EnvironmentSpec(procedural="sky", width=width, sun_azimuth_deg=azimuth)


def _live(textures) -> int:
    """How many of ``textures`` are still GL textures (glIsTexture on their names)."""
    from viewer.environment.ibl_build import _gl

    if _gl() is None:
        pytest.skip("no GL dispatch library to ask glIsTexture")
    lib = ctypes.CDLL("libOpenGL.so.0")
    lib.glIsTexture.argtypes = [ctypes.c_uint]
    lib.glIsTexture.restype = ctypes.c_ubyte
    return sum(int(lib.glIsTexture(t)) for t in textures)


@pytest.fixture
def store(programs):
    s = EnvironmentStore(programs, options=OPTS, disk=None)
    yield s
    s.release()


def test_store_semantics(store):
    spec = sky()
    env = load_environment(spec)
    residual, sun = extract_sun(env)
    plain = store.ibl(spec)
    sunless = store.ibl(spec, sun=True)
    assert plain.sun is None and sunless.sun == sun == store.sun(spec)
    assert sunless.full_prefiltered is plain.prefiltered and sunless.radiance is plain.radiance
    np.testing.assert_array_equal(store.power_directions(spec), power_directions(env))
    # the sun-less IBL's level 0 is the residual, its SH the residual's; the plain IBL's the env's
    np.testing.assert_array_equal(sunless.read_level("prefiltered", 0)[..., :3], residual)
    np.testing.assert_array_equal(plain.read_level("radiance", 0)[..., :3], env)
    assert not np.allclose(plain.sh, sunless.sh)
    # intensity and rotation are uniforms: the same entry
    turned = dataclasses.replace(spec, intensity=3.0, rotation_deg=90.0)
    assert store.ibl(turned, sun=True) is sunless and store.environments == 1
    # no sun: sun=True gives the plain IBL
    white = EnvironmentSpec(procedural="white", width=64)
    assert store.sun(white) is None and store.ibl(white, sun=True) is store.ibl(white)
    # the sampling tables: built once, from the radiance, as before
    sampling = store.env_sampling(spec)
    assert store.env_sampling(spec) is sampling
    ref = build_env_sampling(store.programs, plain.radiance)
    try:
        for name, arr in ref.read().items():
            np.testing.assert_array_equal(sampling.read()[name], arr)
    finally:
        ref.release()
    stats = store.stats()
    assert stats.items == 2 and stats.misses == 2 and stats.hits >= 6


def test_byte_bound_evicts_and_releases_textures(store, programs):
    """Beyond max_bytes the least recently used environment goes, and its GL textures with it
    (counted with glIsTexture); pinned environments stay while pinned."""
    a, b, c = sky(0.0), sky(90.0), sky(180.0)
    store.ibl(a, sun=True)
    entry_a = store._cache.get(store.key(a))
    names_a = [t.glo for t in entry_a.textures()]
    one = store.stats().bytes
    assert one == entry_a.nbytes > 0 and _live(names_a) == len(names_a) >= 3
    store.resize(int(1.5 * one))
    store.ibl(b, sun=True)
    assert store.environments == 1 and store.stats().evictions == 1
    assert store.key(a) not in store._cache and _live(names_a) == 0
    assert store.stats().bytes <= int(1.5 * one)
    entry_b = store._cache.get(store.key(b))
    names_b = [t.glo for t in entry_b.textures()]
    with store.pinned(b):
        store.ibl(c)
        assert store.environments == 2  # over budget while b is pinned
        assert _live(names_b) == len(names_b)
    # unpinned: the trim at the pin's end keeps b (what was pinned: the environment in use is
    # never evicted by it) and frees c; a new environment then needs the room and b goes
    assert store.environments == 1 and store.key(b) in store._cache
    assert _live(names_b) == len(names_b)
    store.ibl(a)
    assert store.environments == 1 and _live(names_b) == 0
    # the sampling tables count too: an entry grows when they are built
    before = store.stats().bytes
    store.env_sampling(a)
    assert store.stats().bytes > before


def test_memory_report(store):
    store.ibl(sky(), sun=True)
    mem = store.memory()
    assert mem["environments"]["items"] == 1
    assert mem["entries"][0]["bytes"] == mem["environments"]["bytes"]
    assert mem["luts_bytes"] == 16 * 16 * (2 + 1) * 4 and mem["disk"] is None


def test_release_frees_every_texture(programs):
    s = EnvironmentStore(programs, options=OPTS, disk=None)
    s.ibl(sky(), sun=True)
    s.env_sampling(sky())
    names = [t.glo for e in s._cache.values() for t in e.textures()]
    names += [t.glo for t in s._lut_textures]
    s.release()
    assert _live(names) == 0 and s.environments == 0


def test_method_before_is_reachable(programs):
    """IBLOptions.legacy(): the plain IBL first, the sun-less one (a second importance-sampled
    chain) on first request, both as build_ibl makes them; the entry grows when it is built."""
    opts = IBLOptions.legacy(prefilter_samples=16, dfg_size=16, dfg_samples=64)
    s = EnvironmentStore(programs, options=opts, disk=None)
    try:
        spec = sky()
        plain = s.ibl(spec)
        before = s.stats().bytes
        sunless = s.ibl(spec, sun=True)
        assert s.stats().bytes > before and sunless.full_prefiltered is plain.prefiltered
        env = load_environment(spec)
        residual, sun = extract_sun(env)
        ref = build_ibl(programs, env, opts, sun=sun, residual=residual)
        try:
            for k in range(ref.levels):
                np.testing.assert_array_equal(sunless.read_level("prefiltered", k),
                                              ref.read_level("prefiltered", k))
        finally:
            ref.release()
    finally:
        s.release()
