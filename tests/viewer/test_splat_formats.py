"""Splat file formats: antimatter15 .splat, SuperSplat compressed PLY, the R3DG and GaussianShader
layouts, detection by content, unsupported formats, bad input and unused-property warnings. Every
fixture is written here with known values."""
import gzip
import struct
import warnings

import numpy as np
import pytest
from plyfile import PlyData, PlyElement

from viewer.errors import InputError
from viewer.splats import read_splats
from viewer.splats.data import SH_C0, quat_to_matrix
from viewer.splats.formats import detect_format, write_splat


def _sigmoid(x):
    return 1.0 / (1.0 + np.exp(-np.asarray(x, np.float64)))


def _unit(q):
    q = np.asarray(q, np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _same_rotation(a, b, atol):
    """Quaternions equal up to sign."""
    a, b = _unit(a), _unit(b)
    d = np.minimum(np.abs(a - b).max(axis=1), np.abs(a + b).max(axis=1))
    assert d.max() <= atol, d.max()


# ---- antimatter15 .splat ------------------------------------------------------------------------

def _splat_fixture(path, n=6):
    rng = np.random.default_rng(0)
    means = rng.normal(size=(n, 3))
    scales = np.exp(rng.uniform(-4, -1, (n, 3)))
    rgba = rng.integers(0, 256, (n, 4)).astype(np.uint8)
    rgba[:, 3] = np.maximum(rgba[:, 3], 10)
    rot = rng.normal(size=(n, 4))
    write_splat(path, means, scales, rgba, rot)
    return means, scales, rgba, rot


@pytest.mark.parametrize("name", ["a.splat", "renamed.ply", "noext"])
def test_splat_records_decode_whatever_the_extension(tmp_path, name):
    p = tmp_path / name
    means, scales, rgba, rot = _splat_fixture(p)
    assert detect_format(p) == "splat"
    s = read_splats(p)
    assert len(s) == 6 and s.sh.shape == (6, 1, 3) and not s.has_materials
    np.testing.assert_allclose(s.means, means, rtol=1e-6)
    np.testing.assert_allclose(s.scales, scales, rtol=1e-6)  # linear sigma, no exp
    np.testing.assert_allclose(s.opacities, rgba[:, 3] / 255.0, rtol=1e-6)
    # baked colour along any direction = the stored rgb (SH degree 0)
    np.testing.assert_allclose(s.sh[:, 0] * SH_C0 + 0.5, rgba[:, :3] / 255.0, atol=1e-6)
    np.testing.assert_allclose(s.albedo, rgba[:, :3] / 255.0, atol=1e-6)
    # quaternion bytes q 128 + 128: 1/256 rounding per component
    _same_rotation(s.rotations, rot, atol=1.5 / 128)


def test_splat_byte_layout_by_hand(tmp_path):
    """One record assembled byte by byte: (w, x, y, z) = bytes (128 + 128, 128, 128, 128 + 90)."""
    rec = struct.pack("<3f3f4B4B", 1.0, -2.0, 3.5, 0.1, 0.2, 0.3, 255, 128, 0, 51,
                      255, 128, 128, 218)
    p = tmp_path / "one.splat"
    p.write_bytes(rec)
    s = read_splats(p)
    np.testing.assert_allclose(s.means[0], [1.0, -2.0, 3.5])
    np.testing.assert_allclose(s.scales[0], [0.1, 0.2, 0.3], rtol=1e-6)
    assert s.opacities[0] == pytest.approx(51 / 255)
    np.testing.assert_allclose(s.albedo[0], [1.0, 128 / 255, 0.0], atol=1e-6)
    np.testing.assert_allclose(s.rotations[0], _unit([127 / 128, 0, 0, 90 / 128]), atol=1e-6)


def test_splat_nan_records_are_dropped_and_implausible_bytes_are_not_splats(tmp_path):
    p = tmp_path / "n.splat"
    _splat_fixture(p)
    data = bytearray(p.read_bytes())
    data[32:36] = struct.pack("<f", float("nan"))  # record 1's x
    p.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match="dropped 1 splats with NaN"):
        assert len(read_splats(p)) == 5
    q = tmp_path / "n.bin"  # the same bytes under another name: not recognised as .splat
    q.write_bytes(bytes(data))
    with pytest.raises(InputError, match="unrecognised splat file format"):
        read_splats(q)


def test_ply_named_splat_is_read_as_ply(tmp_path):
    from viewer.splats import write_ply
    from viewer.splats.generate import sphere_splats

    p = tmp_path / "actually_a_ply.splat"
    write_ply(p, sphere_splats(50))
    assert detect_format(p) == "ply"
    s = read_splats(p)
    assert len(s) == 50 and s.has_materials


@pytest.mark.parametrize("case,needle", [
    ("truncated", "not a whole number of 32-byte records"),
    ("garbage_ply", "not a readable PLY file"),
    ("unknown", "unrecognised splat file format"),
    ("spz", "Niantic .spz splat files are not supported"),
    ("spz_raw", "Niantic .spz splat files are not supported"),
    ("ksplat", ".ksplat (GaussianSplats3D) splat files are not supported"),
    ("gzip", "not a .spz splat file"),
])
def test_bad_and_unsupported_files_are_one_line_errors(tmp_path, case, needle):
    ext = {"garbage_ply": ".ply", "unknown": ".dat", "spz": ".spz", "spz_raw": ".spz",
           "ksplat": ".ksplat", "gzip": ".gz"}.get(case, ".splat")
    p = tmp_path / f"bad{ext}"
    if case == "truncated":
        _splat_fixture(p)
        p.write_bytes(p.read_bytes()[:-7])
    elif case in ("garbage_ply", "unknown"):
        p.write_bytes(b"this is not a splat file\n" * 64)  # 1600 bytes: a multiple of 32
    elif case == "spz":
        header = b"NGSP" + struct.pack("<2I4B", 2, 10, 0, 12, 0, 0)
        p.write_bytes(gzip.compress(header + bytes(200)))
    elif case == "spz_raw":
        p.write_bytes(b"NGSP" + struct.pack("<2I4B", 3, 10, 0, 12, 0, 0) + bytes(100))
    elif case == "ksplat":
        head = bytearray(4096)
        head[0], head[1] = 0, 1
        struct.pack_into("<4IH", head, 4, 1, 1, 1000, 1000, 0)
        p.write_bytes(bytes(head) + bytes(1024 + 44 * 1000))
    elif case == "gzip":
        p.write_bytes(gzip.compress(b"hello world" * 10))
    with pytest.raises(InputError) as exc:
        read_splats(p)
    msg = str(exc.value)
    assert needle in msg and "\n" not in msg and p.name in msg
    assert "not a readable PLY" not in msg or ext == ".ply"


# ---- SuperSplat compressed PLY ------------------------------------------------------------------

def _pack_111011(t):
    t = np.asarray(t)
    q = np.round(t * [2047, 1023, 2047]).astype(np.uint32)
    return (q[:, 0] << 21) | (q[:, 1] << 11) | q[:, 2]


def _pack_rotation(q):
    """Encoder written from the format description (not the decoder): largest |component| in
    (w, x, y, z) dropped, its sign made positive, the others 10 bits each."""
    q = _unit(q)
    largest = np.argmax(np.abs(q), axis=1)
    q = q * np.sign(q[np.arange(len(q)), largest])[:, None]
    out = (largest.astype(np.uint32) << 30)
    for i in range(len(q)):
        rest = [q[i, j] for j in range(4) if j != largest[i]]
        u = [int(round((v / np.sqrt(2) + 0.5) * 1023)) for v in rest]
        out[i] |= (u[0] << 20) | (u[1] << 10) | u[2]
    return out


def _compressed_fixture(path, n=300, with_sh=True, with_color_range=True, extra_vertex=False):
    rng = np.random.default_rng(7)
    n_chunks = -(-n // 256)
    lo = rng.uniform(-2, 0, (n_chunks, 3))
    hi = lo + rng.uniform(0.5, 2, (n_chunks, 3))
    slo = rng.uniform(-5, -3, (n_chunks, 3))
    shi = slo + rng.uniform(0.5, 2, (n_chunks, 3))
    clo = rng.uniform(-0.2, 0.2, (n_chunks, 3))
    chi = clo + 1.0
    tp = rng.integers(0, [2048, 1024, 2048], (n, 3)) / np.array([2047, 1023, 2047])
    ts = rng.integers(0, [2048, 1024, 2048], (n, 3)) / np.array([2047, 1023, 2047])
    rgba = rng.integers(0, 256, (n, 4))
    rot = rng.normal(size=(n, 4))
    names = ["min_x", "min_y", "min_z", "max_x", "max_y", "max_z", "min_scale_x", "min_scale_y",
             "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z"]
    if with_color_range:
        names += ["min_r", "min_g", "min_b", "max_r", "max_g", "max_b"]
    chunk = np.zeros(n_chunks, dtype=[(c, "f4") for c in names])
    vals = [lo, hi, slo, shi] + ([clo, chi] if with_color_range else [])
    for i, c in enumerate(names):
        chunk[c] = vals[i // 3][:, i % 3]
    vdt = [("packed_position", "u4"), ("packed_rotation", "u4"), ("packed_scale", "u4"),
           ("packed_color", "u4")] + ([("temperature", "f4")] if extra_vertex else [])
    vert = np.zeros(n, dtype=vdt)
    vert["packed_position"] = _pack_111011(tp)
    vert["packed_scale"] = _pack_111011(ts)
    vert["packed_color"] = ((rgba[:, 0] << 24) | (rgba[:, 1] << 16) | (rgba[:, 2] << 8)
                            | rgba[:, 3]).astype(np.uint32)
    vert["packed_rotation"] = _pack_rotation(rot)
    els = [PlyElement.describe(chunk, "chunk"), PlyElement.describe(vert, "vertex")]
    sh_bytes = rng.integers(0, 256, (n, 9))
    if with_sh:
        sh = np.zeros(n, dtype=[(f"f_rest_{i}", "u1") for i in range(9)])
        for i in range(9):
            sh[f"f_rest_{i}"] = sh_bytes[:, i]
        els.append(PlyElement.describe(sh, "sh"))
    PlyData(els).write(str(path))
    ci = np.arange(n) // 256
    f32 = lambda a: a.astype(np.float32).astype(np.float64)  # noqa: E731 (chunk data is float32)
    expect = {
        "means": f32(lo)[ci] * (1 - tp) + f32(hi)[ci] * tp,
        "scales": np.exp(f32(slo)[ci] * (1 - ts) + f32(shi)[ci] * ts),
        "color": (f32(clo)[ci] * (1 - rgba[:, :3] / 255) + f32(chi)[ci] * rgba[:, :3] / 255
                  if with_color_range else rgba[:, :3] / 255),
        "opacity": rgba[:, 3] / 255, "rot": rot, "sh_bytes": sh_bytes,
    }
    return expect


def test_supersplat_compressed_ply(tmp_path):
    p = tmp_path / "c.compressed.ply"
    e = _compressed_fixture(p)
    s = read_splats(p)
    assert len(s) == 300 and s.sh_degree == 1
    np.testing.assert_allclose(s.means, e["means"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(s.scales, e["scales"], rtol=1e-5)
    np.testing.assert_allclose(s.opacities, e["opacity"], rtol=1e-6)
    np.testing.assert_allclose(s.sh[:, 0] * SH_C0 + 0.5, e["color"], atol=1e-5)
    _same_rotation(s.rotations, e["rot"], atol=2e-3)  # 10-bit components
    # sh: u 8 / 255 - 4, channel-major: f_rest_3 is green's first higher coefficient
    np.testing.assert_allclose(s.sh[:, 1, 1], e["sh_bytes"][:, 3] * 8 / 255 - 4, atol=1e-5)
    np.testing.assert_allclose(s.sh[:, 3, 2], e["sh_bytes"][:, 8] * 8 / 255 - 4, atol=1e-5)


def test_compressed_ply_bits_by_hand(tmp_path):
    """One splat: position bits (2047, 0, 1023) -> (max_x, min_y, mid z); rotation mode 2 (y
    largest) with the others at code 511.5 -> ~0: q ~ (0, 0, 1, 0)."""
    chunk = np.zeros(1, dtype=[(c, "f4") for c in (
        "min_x", "min_y", "min_z", "max_x", "max_y", "max_z", "min_scale_x", "min_scale_y",
        "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z")])
    chunk["max_x"] = chunk["max_y"] = chunk["max_z"] = 2.0
    chunk["min_scale_x"] = chunk["min_scale_y"] = chunk["min_scale_z"] = -3.0
    vert = np.zeros(1, dtype=[(c, "u4") for c in ("packed_position", "packed_rotation",
                                                  "packed_scale", "packed_color")])
    vert["packed_position"] = (2047 << 21) | (0 << 11) | 1023
    vert["packed_rotation"] = (2 << 30) | (512 << 20) | (512 << 10) | 512
    vert["packed_scale"] = 0  # min scales: sigma = e^-3
    vert["packed_color"] = (255 << 24) | (0 << 16) | (255 << 8) | 204
    p = tmp_path / "one.ply"
    PlyData([PlyElement.describe(chunk, "chunk"), PlyElement.describe(vert, "vertex")]).write(
        str(p))
    s = read_splats(p)
    np.testing.assert_allclose(s.means[0], [2.0, 0.0, 2.0 * 1023 / 2047], rtol=1e-6)
    np.testing.assert_allclose(s.scales[0], np.exp(-3.0), rtol=1e-6)
    np.testing.assert_allclose(s.rotations[0], [0, 0, 1, 0], atol=2e-3)
    np.testing.assert_allclose(s.albedo[0], [1.0, 0.0, 1.0], atol=1e-6)
    assert s.opacities[0] == pytest.approx(0.8)


def test_compressed_ply_without_sh_or_colour_range_and_bad_chunks(tmp_path):
    p = tmp_path / "c.ply"
    e = _compressed_fixture(p, n=40, with_sh=False, with_color_range=False, extra_vertex=True)
    with pytest.warns(UserWarning, match=r"c\.ply: ignored PLY properties .*temperature"):
        s = read_splats(p)
    assert s.sh_degree == 0
    np.testing.assert_allclose(s.albedo, e["color"], atol=1e-6)
    # 300 splats need 2 chunks: drop one
    q = tmp_path / "bad.ply"
    _compressed_fixture(q, n=300)
    ply = PlyData.read(str(q), mmap=False)
    els = [PlyElement.describe(ply["chunk"].data[:1], "chunk"),
           PlyElement.describe(ply["vertex"].data, "vertex")]
    PlyData(els).write(str(q))
    with pytest.raises(InputError, match=r"bad\.ply: compressed PLY: 1 chunks for 300 splats"):
        read_splats(q)


# ---- relightable layouts ----------------------------------------------------------------------

def _vertex(n, names, seed=3):
    rng = np.random.default_rng(seed)
    arr = np.zeros(n, dtype=[(nm, "f4") for nm in names])
    for nm in names:
        arr[nm] = rng.normal(size=n)
    return arr


BASE = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0",
        "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]


def test_r3dg_layout(tmp_path):
    names = BASE + [f"f_rest_{i}" for i in range(9)] + ["base_color_0", "base_color_1",
                                                        "base_color_2", "roughness"]
    names += ["incidents_dc_0", "incidents_dc_1", "incidents_dc_2"]
    names += [f"incidents_rest_{i}" for i in range(9)]
    names += ["visibility_dc_0"] + [f"visibility_rest_{i}" for i in range(15)]
    arr = _vertex(8, names)
    p = tmp_path / "r3dg.ply"
    PlyData([PlyElement.describe(arr, "vertex")]).write(str(p))
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        s = read_splats(p)
    msgs = [str(w.message) for w in rec]
    assert len(msgs) == 1, msgs
    assert ("r3dg.ply: ignored PLY properties not used by the R3DG layout: incidents_dc_0..2, "
            "incidents_rest_0..8, visibility_dc_0, visibility_rest_0..14") in msgs[0]
    assert s.has_materials and s.sh_degree == 1
    base = np.stack([arr[f"base_color_{i}"] for i in range(3)], -1)
    np.testing.assert_allclose(s.albedo, 0.77 * _sigmoid(base) + 0.03, rtol=1e-6)
    np.testing.assert_allclose(s.roughness, 0.9 * _sigmoid(arr["roughness"]) + 0.09, rtol=1e-6)
    assert np.all(s.metallic == 0)
    nxyz = np.stack([arr[c] for c in ("nx", "ny", "nz")], -1)
    np.testing.assert_allclose(s.normals, _unit(nxyz), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(s.opacities, _sigmoid(arr["opacity"]), rtol=1e-6)
    np.testing.assert_allclose(s.sh[:, 2, 0], arr["f_rest_1"])


def test_gaussianshader_layout(tmp_path):
    names = BASE + ["nx2", "ny2", "nz2", "roughness", "specular0", "specular1", "specular2"]
    arr = _vertex(9, names)
    for c in ("f_dc_0", "f_dc_1", "f_dc_2"):
        arr[c] = np.random.default_rng(5).uniform(-0.2, 1.2, 9)  # diffuse colour, some clamped
    for c in ("nx", "ny", "nz"):
        arr[c] *= 0.1  # a small residual on top of the shortest axis
    p = tmp_path / "gshader.ply"
    PlyData([PlyElement.describe(arr, "vertex")]).write(str(p))
    with pytest.warns(UserWarning) as rec:
        s = read_splats(p)
    msgs = " | ".join(str(w.message) for w in rec)
    assert "not used by the GaussianShader layout: nx2, ny2, nz2" in msgs
    diffuse = np.stack([arr[f"f_dc_{i}"] for i in range(3)], -1)
    np.testing.assert_allclose(s.albedo, np.clip(diffuse, 0, 1), rtol=1e-6)
    np.testing.assert_allclose(s.sh[:, 0] * SH_C0 + 0.5, np.clip(diffuse, 0, 1), atol=1e-6)
    np.testing.assert_allclose(s.roughness, _sigmoid(arr["roughness"]), rtol=1e-6)
    spec = np.stack([arr[f"specular{i}"] for i in range(3)], -1)
    np.testing.assert_allclose(s.metallic, _sigmoid(spec).mean(axis=1), rtol=1e-6)
    q = _unit(np.stack([arr[f"rot_{i}"] for i in range(4)], -1))
    sc = np.stack([arr[f"scale_{i}"] for i in range(3)], -1)
    axis = quat_to_matrix(q)[np.arange(9), :, np.argmin(sc, axis=1)]
    delta = np.stack([arr[c] for c in ("nx", "ny", "nz")], -1)
    np.testing.assert_allclose(s.normals, _unit(axis + delta), rtol=1e-5, atol=1e-6)


def test_gsir_and_3dgs_warn_unused_once(tmp_path):
    names = BASE + ["albedo_0", "albedo_1", "albedo_2", "roughness", "metallic", "red", "green"]
    arr = _vertex(4, names)
    for c in ("nx", "ny", "nz"):
        arr[c] = 0.0  # INRIA's placeholder zeros: consumed silently
    face = np.zeros(2, dtype=[("vertex_indices", "i4", (3,))])
    p = tmp_path / "gsir.ply"
    PlyData([PlyElement.describe(arr, "vertex"), PlyElement.describe(face, "face")]).write(str(p))
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        s = read_splats(p)
    unused = [str(w.message) for w in rec if "ignored PLY properties" in str(w.message)]
    assert len(unused) == 1
    assert unused[0].endswith("GS-IR layout: red, green; element 'face' (vertex_indices)")
    assert s.has_materials and np.all(s.normals == 0)


# ---- rendering a loaded file -------------------------------------------------------------------

SCENE = """
[camera]
position = [0, 0.2, 3]
fov_y = 40
size = [40, 32]
[environment]
procedural = "studio"
[render]
background = "transparent"
[[objects]]
type = "splats"
path = "{path}"
"""


def test_cli_renders_a_splat_file(tmp_path):
    """``relight render`` on an antimatter15 .splat converted from the sphere fixture: coverage
    where the sphere is, no NaN."""
    from relight.cli import main
    from viewer.imageio import read_image
    from viewer.splats.generate import sphere_splats

    s = sphere_splats(800)
    rgba = np.concatenate([np.round(s.albedo * 255), np.round(s.opacities[:, None] * 255)], 1)
    write_splat(tmp_path / "ball.splat", s.means, s.scales, rgba.astype(np.uint8), s.rotations)
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(path="ball.splat"))
    out = tmp_path / "o.exr"
    assert main(["render", str(scene), "--out", str(out), "--aov", "alpha", "-q"]) == 0
    img = read_image(out)[0]
    a = read_image(tmp_path / "o.alpha.exr")[0][..., 0]
    assert np.all(np.isfinite(img))
    assert a[16, 20] > 0.9 and a.mean() > 0.1 and a[0, 0] == 0
