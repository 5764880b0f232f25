"""The frame graph (viewer/graph): culling, reuse derived from the declared inputs, in-place chains,
volatile passes, transient pooling and the pool's bounds; and on the renderer's own frame, that
changing each declared input redraws exactly the passes downstream of it (and the result is the
frame drawing every pass makes, bit for bit)."""
import dataclasses

import numpy as np
import pytest

from viewer.graph import FrameGraph, TargetPool, TextureDesc

SMALL = TextureDesc((8, 4), 4, "f4")


def _graph(pool, log, inputs=None, reuse=True, extra=False):
    """a -> t (transient) -> b -> k (kept) -> c (in place on k) ; side d writes an unread x."""
    inputs = inputs or {}
    g = FrameGraph(pool, reuse=reuse)
    g.create("t", SMALL)
    g.create("k", SMALL, kept=True)
    g.create("x", SMALL)

    def run(name):
        def execute(f):
            log.append(name)
            for w in {"a": ["t"], "b": ["k"], "c": ["k"], "d": ["x"]}[name]:
                f[w].fbo.clear(float(len(log)), 0.0, 0.0, 1.0)
        return execute
    g.add_pass("a", run("a"), writes=("t",), inputs={"a": inputs.get("a", 0)})
    g.add_pass("b", run("b"), reads=("t",), writes=("k",), inputs={"b": inputs.get("b", 0)})
    g.add_pass("c", run("c"), reads=("k",), writes=("k",), inputs={"c": inputs.get("c", 0)})
    if extra:
        g.add_pass("d", run("d"), reads=("k",), writes=("x",))
    return g


@pytest.fixture
def pool(ctx):
    p = TargetPool(ctx, max_bytes=1 << 20, max_age=2)
    yield p
    p.clear()


def _status(g):
    return {p["name"]: p["status"] for p in g.describe()["passes"]}


def test_culls_passes_nothing_reads(pool):
    log = []
    g = _graph(pool, log, extra=True).compile()
    assert _status(g)["d"] == "culled"
    g.execute()
    assert log == ["a", "b", "c"]


def test_reuse_follows_the_declared_inputs(pool):
    log = []
    _graph(pool, log).compile().execute()
    assert log == ["a", "b", "c"]
    log.clear()
    g = _graph(pool, log).compile()
    g.execute()
    assert log == [] and set(_status(g).values()) == {"reused"}, _status(g)
    # an input of the last in-place writer: the whole chain on k is drawn again (c continues b's
    # content), and a, whose transient only b reads, with it
    log.clear()
    _graph(pool, log, {"c": 1}).compile().execute()
    assert log == ["a", "b", "c"]
    log.clear()
    _graph(pool, log, {"c": 1}).compile().execute()
    assert log == []
    log.clear()
    g = _graph(pool, log, {"a": 1, "c": 1}).compile()
    assert "changed: a" in " ".join(p.why for p in g.passes if p.name == "b") or \
        "(read)" in " ".join(p.why for p in g.passes if p.name == "b")
    g.execute()
    assert log == ["a", "b", "c"]


def test_reuse_off_draws_everything(pool):
    log = []
    _graph(pool, log).compile().execute()
    log.clear()
    _graph(pool, log, reuse=False).compile().execute()
    assert log == ["a", "b", "c"]


def test_a_volatile_pass_is_never_reused_nor_what_follows(pool):
    log = []
    for _ in range(2):
        g = FrameGraph(pool)
        g.create("k", SMALL, kept=True)
        g.create("out", SMALL, kept=True)
        g.add_pass("mc", lambda f: log.append("mc"), writes=("k",), volatile=True)
        g.add_pass("tone", lambda f: log.append("tone"), reads=("k",), writes=("out",))
        g.compile().execute()
    assert log == ["mc", "tone", "mc", "tone"]


def test_transients_with_disjoint_lifetimes_share_a_target(pool):
    seen = []
    g = FrameGraph(pool)
    for name in ("t1", "t2", "t3"):
        g.create(name, SMALL)
    g.create("out", SMALL, kept=True)
    g.add_pass("p1", lambda f: seen.append(f["t1"].texture.glo), writes=("t1",))
    g.add_pass("p2", lambda f: seen.append(f["t2"].texture.glo), reads=("t1",), writes=("t2",))
    g.add_pass("p3", lambda f: seen.append(f["t3"].texture.glo), reads=("t2",), writes=("t3",))
    g.add_pass("p4", lambda f: None, reads=("t3",), writes=("out",))
    g.compile().execute()
    # t1 and t2 are alive together (p2 reads t1, writes t2); t3 takes t1's target back
    assert seen[0] != seen[1] and seen[2] == seen[0]
    assert pool.created == 3  # t1/t3, t2, out


def test_pool_ages_out_and_bounds_bytes(ctx):
    pool = TargetPool(ctx, max_bytes=3 * SMALL.bytes(), max_age=2)
    try:
        for w in range(6):  # six kept sizes in a row: old ones go back to the pool, then age out
            g = FrameGraph(pool)
            g.create("k", TextureDesc((8 + w, 4)), kept=True)
            g.add_pass("p", lambda f: None, writes=("k",))
            g.compile().execute()
            assert pool.bytes <= 3 * SMALL.bytes() + TextureDesc((8 + w, 4)).bytes()
        assert pool.destroyed >= 3
        live = pool.stats().items
        for _ in range(4):  # frames without the kept target: it is freed after max_age
            g = FrameGraph(pool)
            g.compile().execute()
        assert pool.stats().items == 0 and pool.bytes == 0 and live >= 1
    finally:
        pool.clear()


def test_undeclared_resource_is_an_error(pool):
    g = FrameGraph(pool)
    with pytest.raises(ValueError, match="undeclared"):
        g.add_pass("p", lambda f: None, reads=("nope",))


def test_dot_names_every_pass_and_resource(pool):
    g = _graph(pool, [], extra=True).compile()
    dot = g.to_dot()
    assert dot.startswith("digraph") and dot.rstrip().endswith("}")
    for name in ("pass:a", "pass:b", "pass:c", "pass:d", "res:t", "res:k", "res:x"):
        assert f'"{name}"' in dot


# ---- the renderer's frame ----------------------------------------------------------------------
from viewer.gl.timing import PassTimer  # noqa: E402
from viewer.renderer import Renderer  # noqa: E402
from viewer.scene.description import ObjectSpec, scene_from_dict  # noqa: E402

BASE = {
    "camera": {"position": [0, 1.2, 2.6], "target": [0, 0.3, 0], "fov_y": 45, "size": [40, 32]},
    "environment": {"procedural": "sky", "width": 64},
    "light": {"direction": [0.3, -1, -0.2], "intensity": 1.5},
    "objects": [
        {"type": "plane", "center": [0, 0, 0], "size": [6, 6], "normal": [0, 1, 0],
         "material": {"albedo": [0.8, 0.8, 0.8], "roughness": 0.7}},
        {"type": "sphere", "center": [0, 0.45, 0], "radius": 0.45,
         "material": {"albedo": [0.9, 0.3, 0.2], "roughness": 0.4}}],
    "render": {"tonemap": "none", "ssao": True, "indirect": True, "ssao_scale": 2,
               "raytrace": False,  # the screen-space passes (rays: their own tests below)
               "ssao_rays": 4, "ssao_steps": 4},
}
GLASS = ObjectSpec(type="mesh", path="in-memory-glass")
SPLATS = ObjectSpec(type="splats", path="in-memory-splats")
LIGHTING = {"shade", "indirect_gather", "indirect", "forward", "tonemap", "fxaa"}
DISPLAY = {"tonemap", "fxaa"}
SSAO = {"ssao", "ssao_upsample", "ssao_blur"}
SHADOWS = {"shadow0", "shadowsun"}  # the [light]'s map and the sky's sun's


def _base():
    sc = scene_from_dict(BASE)
    return dataclasses.replace(sc, objects=sc.objects + (GLASS, SPLATS))


def _env(**kw):
    return lambda s: dataclasses.replace(s, environment=dataclasses.replace(s.environment, **kw))


def _sphere(**kw):
    def change(s):
        objs = list(s.objects)
        objs[1] = dataclasses.replace(objs[1], **kw)
        return dataclasses.replace(s, objects=tuple(objs))
    return change


def _material(s):
    objs = list(s.objects)
    objs[1] = dataclasses.replace(objs[1], material=dataclasses.replace(objs[1].material,
                                                                        albedo=(0.1, 0.5, 0.9)))
    return dataclasses.replace(s, objects=tuple(objs))


# each declared input -> the passes that must be drawn again (exactly these)
CHANGES = {
    "exposure": (lambda s: s.with_render(exposure=1.0), DISPLAY),
    "tone mapper": (lambda s: s.with_render(tonemap="aces"), DISPLAY),
    # without FXAA the tone mapping pass writes the display itself
    "anti-aliasing": (lambda s: s.with_render(aa="none"), {"tonemap"}),
    "environment intensity": (_env(intensity=1.6), LIGHTING),
    "environment rotation": (_env(rotation_deg=30.0), LIGHTING | {"shadowsun"}),
    "light intensity": (lambda s: dataclasses.replace(
        s, lights=(dataclasses.replace(s.lights[0], intensity=3.0),)), LIGHTING),
    # blinn_phong shades no analytic sun: the sun's map goes, and light 0's, which shared the
    # shadow budget with it, is drawn again at the full size
    "model": (lambda s: s.with_render(model="blinn_phong"), LIGHTING | {"shadow0"}),
    "ssao radius": (lambda s: s.with_render(ssao_radius=0.9), SSAO | LIGHTING),
    "seed": (lambda s: s.with_render(seed=7), SSAO | LIGHTING),
    # splats are composited into the G-buffer in place: redrawing them starts from the meshes
    "splat depth": (lambda s: s.with_render(splat_depth="median"),
                    {"gbuffer", "splats"} | SSAO | LIGHTING),
    "material": (_material, {"gbuffer", "splats"} | SSAO | LIGHTING),
    "geometry": (_sphere(center=(0.2, 0.45, 0.0)),
                 {"gbuffer", "splats"} | SSAO | LIGHTING | SHADOWS),
    "camera": (lambda s: s.with_camera(position=(0.3, 1.2, 2.6)),
               {"gbuffer", "splats"} | SSAO | LIGHTING),
}


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.geometry.primitives import sphere
    from viewer.splats.generate import sphere_splats

    r = Renderer(ctx=ctx)
    r.profiler = PassTimer(ctx)
    glass = sphere(center=(0.5, 0.3, 0.5), radius=0.2)
    glass.alpha_mode = "BLEND"
    r.add_geometry(GLASS, [glass])
    cloud = sphere_splats(300, radius=0.25)
    cloud.means[:] += np.array([-0.6, 0.3, 0.2], np.float32)
    r.add_geometry(SPLATS, cloud)
    yield r
    r.release()


def _drawn(renderer, scene):
    timer = renderer.profiler
    timer.enabled = True
    timer.reset()
    try:
        frame = renderer.render(scene)
        return frame.radiance, set(timer.milliseconds()) - {"ibl"}
    finally:
        timer.enabled = False


def test_the_frame_declares_every_pass(renderer):
    g = renderer.graph(_base())
    assert [p.name for p in g.passes] == ["gbuffer", "splats", "ssao", "ssao_upsample",
                                          "ssao_blur", "shadow0", "shadowsun", "shade",
                                          "indirect_gather", "indirect", "forward", "tonemap",
                                          "fxaa"]


@pytest.mark.parametrize("change", list(CHANGES))
def test_a_change_redraws_exactly_what_is_downstream(renderer, change):
    make, expected = CHANGES[change]
    scene = _base()
    _drawn(renderer, scene)
    img, drawn = _drawn(renderer, scene)
    assert drawn == set(), drawn  # nothing changed: nothing drawn
    changed = make(scene)
    img, drawn = _drawn(renderer, changed)
    assert drawn == expected, (change, drawn)
    with renderer.every_pass():
        full, every = _drawn(renderer, changed)
    # every pass the changed frame declares (blinn_phong shades no analytic sun: no shadowsun)
    assert every == ({"gbuffer", "splats"} | SSAO | LIGHTING | SHADOWS) - (
        {"shadowsun"} if change == "model" else set()) - (
        {"fxaa"} if change == "anti-aliasing" else set())
    np.testing.assert_array_equal(img, full)


def test_relight_graph_explains_reuse(renderer):
    scene = _base()
    renderer.draw(scene)
    g = renderer.graph(scene.with_render(exposure=2.0))
    why = {p.name: p.why for p in g.passes}
    assert why["fxaa"] == "display changed: tonemapped (read)", why
    assert why["tonemap"] == "tonemapped changed: exposure", why
    renderer.draw(scene.with_render(aa="none"))
    g = renderer.graph(scene.with_render(aa="none", exposure=2.0))
    why = {p.name: p.why for p in g.passes}
    assert why["tonemap"] == "display changed: exposure", why
    assert why["gbuffer"] == "inputs unchanged"
