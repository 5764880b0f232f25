"""Bounded caches of geometry, uploads and programs: budgets hold, eviction releases the GL objects
(counted for real: viewer.gl.tracking wraps the context's factories), evicted content comes back
identical, and an upload is never handed out for a new object that reused a dead one's id()."""
import dataclasses

import numpy as np
import pytest

from viewer.errors import SceneError
from viewer.gbuffer import GBufferLayout
from viewer.geometry.cache import GeometryCache
from viewer.geometry.primitives import sphere
from viewer.gl import Programs
from viewer.gl.tracking import track_objects
from viewer.passes import FullscreenDraw
from viewer.passes.gbuffer import GBufferPass, GBufferTargets
from viewer.passes.splats import SplatPass
from viewer.passes.uploads import UploadCache
from viewer.renderer import Renderer
from viewer.scene.camera import Camera
from viewer.scene.description import ObjectSpec, scene_from_dict
from viewer.scene.material import Material
from viewer.splats.data import make_splats

BASE = {
    "camera": {"position": [0, 0.4, 2.4], "target": [0, 0.2, 0], "fov_y": 45, "size": [32, 24]},
    "environment": {"procedural": "sky", "width": 64},
    "objects": [],
    # no shadow maps: the counts below are the G-buffer pass's copies (the shadow pass keeps its
    # own, released the same way: tests/viewer/test_shadows.py)
    "render": {"tonemap": "none", "shadows": False, "raytrace": False},
}
CAM = Camera(position=(0.0, 0.0, 2.5), target=(0.0, 0.0, 0.0), fov_y=40.0, size=(32, 32))


@pytest.fixture
def tracker(ctx):
    t = track_objects(ctx)
    yield t
    t.uninstall()


def _write_obj(path, radius, center, segments=12, rings=6):
    mesh = sphere(center=center, radius=radius, segments=segments, rings=rings)
    lines = ["v %.6f %.6f %.6f" % tuple(v) for v in mesh.positions]
    lines += ["f %d %d %d" % tuple(t + 1) for t in mesh.indices]
    path.write_text("\n".join(lines) + "\n")
    return path


def _mesh_scene(path, **render):
    return scene_from_dict({**BASE, "objects": [{"type": "mesh", "path": str(path),
                                                 "material": {"albedo": [0.8, 0.4, 0.2]}}],
                            "render": {**BASE["render"], **render}})


def _renderer(ctx, geometry_bytes=None, programs=None):
    r = Renderer(ctx=ctx)
    r.geometry_cache.resize(geometry_bytes)
    if programs is not None:
        r.programs.resize(programs)
    return r


# ---- geometry -----------------------------------------------------------------------------------
def test_fifty_meshes_stay_within_the_geometry_budget_with_unchanged_images(ctx, tmp_path):
    files = [_write_obj(tmp_path / f"m{i}.obj", 0.3 + 0.01 * i, (0.02 * i - 0.5, 0.2, 0.0))
             for i in range(50)]
    bounded, unbounded = _renderer(ctx), _renderer(ctx)
    try:
        first = bounded.render(_mesh_scene(files[0])).radiance
        one = bounded.geometry_cache.stats().bytes  # CPU arrays + the G-buffer pass's copies
        assert bounded.geometry_cache.gpu_bytes > 0
        budget = int(2.5 * one)
        bounded.geometry_cache.resize(budget)
        for path in files:
            scene = _mesh_scene(path)
            img = bounded.render(scene).radiance
            assert bounded.geometry_cache.stats().bytes <= budget
            np.testing.assert_array_equal(img, unbounded.render(scene).radiance)
        stats = bounded.geometry_cache.stats()
        assert stats.items <= 2 and stats.evictions >= 47
        assert unbounded.geometry_cache.stats().items == 50
        # the first mesh was evicted long ago: loaded and uploaded again, the same image
        np.testing.assert_array_equal(bounded.render(_mesh_scene(files[0])).radiance, first)
    finally:
        bounded.release()
        unbounded.release()


def _textured(i):
    rng = np.random.default_rng(i)
    mesh = sphere(center=(0.1 * i - 0.2, 0.2, 0.0), radius=0.35, segments=12, rings=6)
    mesh.textures = {"base_color": rng.random((8, 8, 3)).astype(np.float32)}
    return [mesh]


def test_eviction_releases_the_gl_objects_of_the_uploads(ctx, tracker):
    r = _renderer(ctx)
    try:
        def show(i):
            obj = ObjectSpec(type="mesh", path=f"in-memory-{i}")
            r.add_geometry(obj, _textured(i))
            scene = dataclasses.replace(scene_from_dict(BASE), objects=(obj,))
            r.render(scene)
            return scene

        scene = show(0)
        r.render(scene)
        r.geometry_cache.resize(r.geometry_cache.stats().bytes)  # room for one textured mesh
        level = tracker.live()
        gpass = r.resources.layout_pass("gbuffer", r.layout_for(scene))
        assert len(gpass.uploads.meshes) == 1 and len(gpass.uploads.textures) == 1
        for i in range(1, 6):  # each evicts the last: its buffers, vertex array, texture
            show(i)
            assert tracker.live() == level, i
            assert len(gpass.uploads.meshes) == 1 and len(gpass.uploads.textures) == 1
        copy = gpass.uploads.meshes.values()[0]
        buffers = len(copy.buffers)
        r.geometry_cache.clear()
        after = tracker.live()
        assert after["Buffer"] == level["Buffer"] - buffers
        assert after["VertexArray"] == level["VertexArray"] - 1
        assert after["Texture"] == level["Texture"] - 1  # the base colour map
        assert r.geometry_cache.stats().bytes == 0 and len(gpass.uploads.meshes) == 0
    finally:
        r.release()


def test_geometry_cache_counts_and_releases_every_pass_copy(ctx, programs, tracker):
    layout = GBufferLayout(with_color=True)
    gpass, spass = GBufferPass(programs, layout), SplatPass(programs, layout)
    targets = GBufferTargets.create(ctx, layout, (32, 32))
    level = tracker.live()
    cache = GeometryCache(max_bytes=None)
    mesh_obj = ObjectSpec(type="sphere", center=(0.0, 0.0, 0.0), radius=0.5, material=Material())
    cloud_obj = ObjectSpec(type="splats", path="in-memory-cloud")
    cache.add(cloud_obj, _cloud())
    meshes = cache.get(mesh_obj)
    cpu = cache.stats().bytes
    assert cpu >= meshes[0].positions.nbytes + meshes[0].indices.nbytes
    targets.clear()
    gpass.draw_meshes(targets, CAM, meshes)
    spass.draw(targets, CAM, cache.get(cloud_obj))
    assert cache.gpu_bytes == gpass.uploads.meshes.bytes + spass.uploads.bytes > 0
    assert cache.stats().bytes == cpu + cache.gpu_bytes
    version = cache.version
    cache.remove(mesh_obj)
    cache.remove(cloud_obj)
    assert cache.version > version
    assert len(gpass.uploads.meshes) == 0 and len(spass.uploads) == 0 and cache.gpu_bytes == 0
    live = tracker.live()  # released at once, the passes still alive
    assert live["Buffer"] == level["Buffer"]
    gpass.release()
    spass.release()
    targets.release()
    live = tracker.live()
    assert live["Buffer"] == level["Buffer"] and live["VertexArray"] == level["VertexArray"]
    assert live["Texture"] == level["Texture"] - len(targets.textures) - 1  # targets: made before


def test_evicted_in_memory_geometry_is_an_error_naming_the_budget():
    cache = GeometryCache(max_bytes=1)  # every entry is over budget: only the newest is kept
    a = ObjectSpec(type="mesh", path="in-memory-a")
    b = ObjectSpec(type="mesh", path="in-memory-b")
    cache.add(a, [sphere(radius=0.2, segments=8, rings=4)])
    version = cache.version
    cache.add(b, [sphere(radius=0.3, segments=8, rings=4)])
    assert len(cache) == 1 and cache.version >= version + 2  # b added, a evicted
    assert cache.get(b)[0].vertex_count > 0
    with pytest.raises(SceneError, match="evicted.*geometry_bytes"):
        cache.get(a)
    cache.add(a, [sphere(radius=0.2, segments=8, rings=4)])  # added again: usable again
    assert cache.get(a)[0].vertex_count > 0


# ---- identity -----------------------------------------------------------------------------------
def _reuse_id(dead_id, make, tries=2000):
    """An object from ``make()`` whose id() is ``dead_id`` (CPython reuses freed memory), or
    None."""
    keep = []
    for _ in range(tries):
        obj = make()
        if id(obj) == dead_id:
            return obj
        keep.append(obj)  # held, so the next one gets other memory
    return None


def test_a_reused_id_never_gets_a_stale_upload(ctx):
    released = []
    cache = UploadCache(ctx, "probe", release=released.append)
    other = np.zeros(3, np.float32)
    a = np.zeros((4, 4, 3), np.float32)
    cache.put(a, None, "copy of a", 10)
    dead = id(a)
    del a
    assert cache.get(other) is None
    assert released == ["copy of a"] and len(cache) == 0  # released when a died (next use)
    cache.put(other, None, "copy of other", 10)
    b = _reuse_id(dead, lambda: np.ones((4, 4, 3), np.float32))
    if b is None:
        pytest.skip("this Python did not reuse the dead array's id")
    assert cache.get(b) is None  # not a's copy
    assert cache.get(other) == "copy of other"


def test_a_mesh_with_a_dead_meshs_id_is_drawn_as_itself(ctx, programs, monkeypatch):
    """Every object gets the same cache key (what a reused id() gives, made certain): a mesh
    drawn after another is drawn as itself, never with the other one's buffers, whether that one
    is still alive or died."""
    from viewer.passes import uploads

    monkeypatch.setattr(uploads, "_key", lambda parts, variant: ("one id", variant))
    layout = GBufferLayout()
    gpass, fresh = GBufferPass(programs, layout), GBufferPass(programs, layout)
    targets = GBufferTargets.create(ctx, layout, (32, 32))
    try:
        a = sphere(center=(-0.4, 0.0, 0.0), radius=0.3, segments=12, rings=6,
                   material=Material(albedo=(0.9, 0.1, 0.1)))
        targets.clear()
        gpass.draw_meshes(targets, CAM, [a])
        first = targets.read(["albedo", "depth"])
        b = sphere(center=(0.4, 0.1, 0.0), radius=0.5, segments=16, rings=8,
                   material=Material(albedo=(0.1, 0.8, 0.2)))
        targets.clear()
        fresh.draw_meshes(targets, CAM, [b])
        want = targets.read(["albedo", "depth"])
        assert not np.array_equal(first["depth"], want["depth"])
        for dies in (False, True):
            if dies:
                gpass.draw_meshes(targets, CAM, [a])  # a's copy under the shared key again
                del a
            targets.clear()
            gpass.draw_meshes(targets, CAM, [b])
            got = targets.read(["albedo", "depth"])
            for k in want:
                np.testing.assert_array_equal(got[k], want[k])
            assert len(gpass.uploads.meshes) == 1  # a's copy was released, b's made
    finally:
        gpass.release()
        fresh.release()
        targets.release()


# ---- splats -------------------------------------------------------------------------------------
def _cloud():
    rng = np.random.default_rng(3)
    n = 60
    return make_splats(rng.normal(0, 0.3, (n, 3)), np.full((n, 3), 0.06),
                       np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), np.full(n, 0.8),
                       albedo=rng.random((n, 3)))


def test_splat_accumulation_targets_are_bounded_and_follow_the_targets(ctx, programs, tracker):
    layout = GBufferLayout(with_color=True)
    spass = SplatPass(programs, layout)
    cloud = _cloud()
    try:
        level = None
        for i, s in enumerate((16, 24, 32, 40, 48)):
            t = GBufferTargets.create(ctx, layout, (s, s))
            t.clear()
            spass.draw(t, CAM, cloud)
            t.release()
            assert len(spass.accum) <= 2
            if i == 2:
                level = tracker.live()
        assert tracker.live() == level  # each new size frees the least recently used one
        # a new G-buffer of a size seen before (its depth texture is new): not the old one's
        t1 = GBufferTargets.create(ctx, layout, (48, 48))
        t1.clear()
        spass.draw(t1, CAM, cloud, depth="median")
        got = t1.read(["alpha", "depth", "color"])
        t1.release()
        fresh = SplatPass(programs, layout)
        t2 = GBufferTargets.create(ctx, layout, (48, 48))
        t2.clear()
        fresh.draw(t2, CAM, cloud, depth="median")
        want = t2.read(["alpha", "depth", "color"])
        fresh.release()
        t2.release()
        for k in want:
            np.testing.assert_array_equal(got[k], want[k])
    finally:
        spass.release()


# ---- programs -----------------------------------------------------------------------------------
def _tonemapped(ctx, programs, draw, tonemap):
    radiance = ctx.texture((8, 8), 4, np.linspace(0, 4, 8 * 8 * 4, dtype=np.float32).tobytes(),
                           dtype="f4")
    out = ctx.texture((8, 8), 4, dtype="f1")
    fbo = ctx.framebuffer([out])
    try:
        prog = programs.graphics("passes/fullscreen.vert", "passes/tonemap.frag",
                                 defines={"TONEMAP": tonemap})
        radiance.use(0)
        prog["u_radiance"].value = 0
        prog["u_exposure"].value = 0.0
        fbo.use()
        ctx.viewport = (0, 0, 8, 8)
        draw(prog)
        return prog, out.read()
    finally:
        for o in (fbo, out, radiance):
            o.release()


def test_programs_are_bounded_by_count_and_rebuilt_identically(ctx, tracker):
    programs = Programs(ctx, max_items=2)
    draw = FullscreenDraw(ctx)
    try:
        first, img = _tonemapped(ctx, programs, draw, 1)
        vaos = tracker.live()["VertexArray"]
        _tonemapped(ctx, programs, draw, 0)
        _tonemapped(ctx, programs, draw, 2)  # evicts TONEMAP 1, the least recently used
        assert len(programs) == 2 and programs.stats().evictions == 1
        assert first not in programs and type(first.mglo).__name__ == "InvalidObject"
        assert tracker.live()["Program"] == 2
        assert tracker.live()["VertexArray"] == vaos + 1  # its vertex array went with it
        again, img2 = _tonemapped(ctx, programs, draw, 1)
        assert again is not first and img2 == img
        with programs.frame():  # nothing looked up in a frame is evicted before it ends
            held = [_tonemapped(ctx, programs, draw, t)[0] for t in (0, 1, 2)]
            assert len(programs) == 3 and all(p in programs for p in held)
        assert len(programs) == 3  # the last frame's working set stays (no recompiles)...
        with programs.frame():
            _tonemapped(ctx, programs, draw, 0)
        assert len(programs) == 2  # ...until a frame that needs less: back within the bound
    finally:
        draw.release()
        programs.release()
    assert tracker.live()["Program"] == 0 and tracker.live()["VertexArray"] == 0


def test_a_renderer_with_two_programs_renders_as_one_with_all(ctx):
    scene = scene_from_dict({**BASE, "objects": [
        {"type": "plane", "center": [0, 0, 0], "size": [4, 4], "normal": [0, 1, 0]},
        {"type": "sphere", "center": [0, 0.4, 0], "radius": 0.4,
         "material": {"albedo": [0.9, 0.3, 0.2], "roughness": 0.4}}],
        # without FXAA: a frame whose G-buffer and SSAO are reused then draws two programs
        "render": {**BASE["render"], "ssao": True, "ssao_rays": 4, "ssao_steps": 4, "aa": "none"}})
    small, full = _renderer(ctx, programs=2), _renderer(ctx)
    try:
        for s in (scene, scene.with_render(model="blinn_phong"), scene):
            np.testing.assert_array_equal(small.render(s).radiance, full.render(s).radiance)
        assert len(small.programs) <= 2 and small.programs.stats().evictions > 5
    finally:
        small.release()
        full.release()
