"""Splat PLY I/O: INRIA layout round trip, GS-IR materials, validation and bad input."""
import numpy as np
import pytest
from plyfile import PlyData, PlyElement

from viewer.errors import InputError
from viewer.splats import read_ply, transform_splats, write_ply
from viewer.splats.data import SH_C0, make_splats, quat_to_matrix, sh_basis_3dgs


def _inria(n=5, k=16, extra=(), text=False):
    """An INRIA-layout vertex array with known values."""
    rng = np.random.default_rng(3)
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(3 * (k - 1))]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    names += list(extra)
    arr = np.zeros(n, dtype=[(nm, "f4") for nm in names])
    for nm in names:
        arr[nm] = rng.normal(size=n)
    arr["rot_0"] = 2.0  # unnormalised, w-first
    return arr


def _without(arr, drop):
    names = [n for n in arr.dtype.names if n != drop]
    out = np.zeros(len(arr), dtype=[(n, "f4") for n in names])
    for n in names:
        out[n] = arr[n]
    return out


def _write(path, arr, text=False):
    PlyData([PlyElement.describe(arr, "vertex")], text=text).write(str(path))


@pytest.mark.parametrize("text", [False, True])
def test_inria_layout_decoding(tmp_path, text):
    arr = _inria()
    p = tmp_path / "a.ply"
    _write(p, arr, text)
    s = read_ply(p)
    assert len(s) == 5 and s.sh.shape == (5, 16, 3) and s.sh_degree == 3
    np.testing.assert_allclose(s.opacities, 1 / (1 + np.exp(-arr["opacity"])), rtol=1e-6)
    np.testing.assert_allclose(s.scales[:, 1], np.exp(arr["scale_1"]), rtol=1e-6)
    q = np.stack([arr[f"rot_{i}"] for i in range(4)], -1)
    np.testing.assert_allclose(s.rotations, q / np.linalg.norm(q, axis=1, keepdims=True),
                               rtol=1e-5, atol=1e-6)
    # f_rest is channel-major: green's first higher coefficient is f_rest_15
    np.testing.assert_allclose(s.sh[:, 1, 1], arr["f_rest_15"])
    np.testing.assert_allclose(s.sh[:, 15, 2], arr["f_rest_44"])
    assert not s.has_materials
    np.testing.assert_allclose(s.albedo, np.clip(s.sh[:, 0] * SH_C0 + 0.5, 0, 1), rtol=1e-6)
    # non-zero nx ny nz are normals (INRIA's own exports write zeros: "none stored")
    nxyz = np.stack([arr[c] for c in ("nx", "ny", "nz")], -1)
    np.testing.assert_allclose(s.normals, nxyz / np.linalg.norm(nxyz, axis=1, keepdims=True),
                               rtol=1e-5, atol=1e-6)


def test_relightable_round_trip(tmp_path):
    arr = _inria(n=7, k=4, extra=("normal_0", "normal_1", "normal_2", "albedo_0", "albedo_1",
                                  "albedo_2", "roughness", "metallic"))
    for nm in ("albedo_0", "albedo_1", "albedo_2", "roughness", "metallic"):
        arr[nm] = np.random.default_rng(1).uniform(0, 1, 7)
    p, q = tmp_path / "a.ply", tmp_path / "b.ply"
    _write(p, arr)
    s = read_ply(p)
    assert s.has_materials and s.sh_degree == 1
    write_ply(q, s)
    t = read_ply(q)
    for k in ("means", "scales", "rotations", "opacities", "sh", "albedo", "roughness",
              "metallic", "normals"):
        np.testing.assert_allclose(getattr(t, k), getattr(s, k), rtol=1e-5, atol=1e-6, err_msg=k)


def test_validation_drops_and_clamps_with_counted_warnings(tmp_path):
    arr = _inria(n=8, k=1, extra=("albedo_0", "albedo_1", "albedo_2", "roughness", "metallic"))
    for nm in ("albedo_0", "albedo_1", "albedo_2", "roughness", "metallic"):
        arr[nm] = 0.5
    arr["x"][0] = np.nan
    arr["rot_0"][1] = arr["rot_1"][1] = arr["rot_2"][1] = arr["rot_3"][1] = 0.0
    arr["scale_0"][2] = 50.0  # exp(50): huge
    arr["scale_1"][3] = -40.0  # ~4e-18: clamped
    arr["roughness"][4] = 1.7
    p = tmp_path / "v.ply"
    _write(p, arr)
    with pytest.warns(UserWarning) as rec:
        s = read_ply(p)
    msgs = " | ".join(str(w.message) for w in rec)
    assert "dropped 1 splats with NaN" in msgs and "zero quaternions" in msgs
    assert "scales above" in msgs and "clamped the scales of 1" in msgs
    assert "clamped the materials of 1" in msgs
    assert len(s) == 5 and s.scales.min() >= 1e-7 and s.roughness.max() <= 1.0
    assert np.all(np.isfinite(s.means))


@pytest.mark.parametrize("case,needle", [
    ("truncated", "truncated or corrupt"),
    ("missing", "missing splat property opacity"),
    ("list", "must be a numeric scalar"),
    ("rest", "f_rest properties"),
    ("garbage", "not a readable PLY"),
    ("nofile", "no such splat file"),
    ("noelement", "no 'vertex' element"),
])
def test_bad_files_are_one_line_input_errors(tmp_path, case, needle):
    p = tmp_path / "bad.ply"
    arr = _inria(n=50, k=4)
    if case == "truncated":
        _write(p, arr)
        data = p.read_bytes()
        p.write_bytes(data[: len(data) - 300])
    elif case == "missing":
        _write(p, _without(arr, "opacity"))
    elif case == "list":
        other = [n for n in arr.dtype.names if n not in ("x", "y", "z", "opacity")]
        # every property present, but opacity is a list
        extra = np.zeros(2, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"),
                                   ("opacity", "O")] + [(n, "f4") for n in other])
        extra["opacity"] = [np.array([1.0, 2.0], np.float32)] * 2
        PlyData([PlyElement.describe(extra, "vertex")]).write(str(p))
    elif case == "rest":
        _write(p, _without(arr, "f_rest_8"))
    elif case == "garbage":
        p.write_bytes(b"this is not a ply\n" * 10)
    elif case == "noelement":
        PlyData([PlyElement.describe(np.zeros(2, dtype=[("a", "f4")]), "face")]).write(str(p))
    with pytest.raises(InputError) as exc:
        read_ply(p)
    msg = str(exc.value)
    assert needle in msg and "\n" not in msg and "bad.ply" in msg


def test_zero_splats_warns_and_loads_empty(tmp_path):
    p = tmp_path / "empty.ply"
    _write(p, _inria(n=0, k=1))
    with pytest.warns(UserWarning, match="no splats"):
        s = read_ply(p)
    assert len(s) == 0


def test_transform_moves_covariances_normals_and_sh():
    rng = np.random.default_rng(0)
    n = 6
    s = make_splats(rng.normal(size=(n, 3)), np.exp(rng.normal(size=(n, 3)) * 0.3),
                    rng.normal(size=(n, 4)), np.full(n, 0.5), sh=rng.normal(size=(n, 16, 3)),
                    normals=rng.normal(size=(n, 3)))
    ang = 0.7
    r = np.array([[np.cos(ang), 0, np.sin(ang)], [0, 1, 0], [-np.sin(ang), 0, np.cos(ang)]])
    m = np.eye(4)
    m[:3, :3] = 2.0 * r
    m[:3, 3] = (1, 2, 3)
    t = transform_splats(s, m)
    np.testing.assert_allclose(t.means, s.means @ (2 * r).T + [1, 2, 3], atol=1e-5)
    np.testing.assert_allclose(t.covariances(), 4 * r @ s.covariances() @ r.T, rtol=1e-4,
                               atol=1e-5)
    nrm = s.normals / np.linalg.norm(s.normals, axis=1, keepdims=True)
    np.testing.assert_allclose(t.normals, nrm @ r.T, atol=1e-5)
    # SH: the world-space colour along R d equals the object-space colour along d
    d = rng.normal(size=(20, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    c_obj = np.einsum("mk,nkc->nmc", sh_basis_3dgs(d), s.sh)
    c_world = np.einsum("mk,nkc->nmc", sh_basis_3dgs(d @ r.T), t.sh)
    np.testing.assert_allclose(c_world, c_obj, atol=1e-4)
    np.testing.assert_allclose(quat_to_matrix(t.rotations) @ np.swapaxes(quat_to_matrix(
        t.rotations), 1, 2), np.broadcast_to(np.eye(3), (n, 3, 3)), atol=1e-5)
