"""The geometry cache against files that change on disk."""


def test_a_file_rewritten_at_the_same_path_is_loaded_again(tmp_path):
    """The cache keys a file's object by its size and modification time too: a splat cloud
    rewritten at the same path (a training loop's output, a re-export) is read again, not drawn
    as it was; an unchanged file is a cache hit."""
    import os

    from viewer.geometry.cache import GeometryCache
    from viewer.scene.description import ObjectSpec
    from viewer.splats import write_ply
    from viewer.splats.generate import sphere_splats

    path = tmp_path / "cloud.ply"
    write_ply(path, sphere_splats(64, seed=0))
    obj = ObjectSpec(type="splats", path=str(path))
    cache = GeometryCache()
    first = cache.get(obj)
    assert cache.get(obj) is first  # unchanged: a hit
    write_ply(path, sphere_splats(96, seed=1))
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))  # coarse-clock file systems
    second = cache.get(obj)
    assert second is not first and len(second.means) == 96
