"""`relight gallery` without the path tracer: the display transform, the error images, the
composed grids, the report files and the command line (its run replaced by a stub)."""
import json
from types import SimpleNamespace

import numpy as np
import pytest

from relight import gallery
from relight.cli import build_parser, main
from relight.gallery import CASES, ERROR_MAX, compose, display, error_image, write_report

WHITE = (255, 255, 255)


# ---- display ------------------------------------------------------------------------------------

def test_display_tone_maps_as_documented():
    # grey g stays grey through both ACES matrices (their rows sum to 1), so each channel is
    # Hill's fit (g(g + 0.0245786) - 0.000090537) / (g(0.983729 g + 0.432951) + 0.238081),
    # sRGB-encoded: g = 1 -> 0.61912 -> 0.80895 -> 206
    out = display(np.ones((2, 3, 4), np.float32))  # the alpha channel is ignored
    assert out.dtype == np.uint8 and out.shape == (2, 3, 3)
    assert (out == 206).all()
    # black stays black, negative radiance is clipped, very bright saturates to white
    assert (display(np.zeros((1, 1, 3))) == 0).all()
    assert (display(np.full((1, 1, 3), -5.0)) == 0).all()
    assert (display(np.full((1, 1, 3), 1e6)) == 255).all()
    # exposure is in stops: +1 EV is twice the radiance
    x = np.linspace(0.0, 4.0, 30).reshape(1, 10, 3)
    np.testing.assert_array_equal(display(x, exposure=1.0), display(2.0 * x))
    np.testing.assert_array_equal(display(x, exposure=-2.0), display(x / 4.0))
    # monotonic in radiance, and the channels stay independent of each other's position
    ramp = display(np.repeat(np.linspace(0.0, 8.0, 50)[:, None, None], 3, axis=2))[:, 0, 0]
    assert (np.diff(ramp.astype(int)) >= 0).all() and ramp[0] == 0 and ramp[-1] > 240
    red = display(np.array([[[1.0, 0.0, 0.0]]]))[0, 0]
    assert red[0] > red[1] and red[0] > red[2]


# ---- error images -------------------------------------------------------------------------------

def _truth(radiance, stderr=0.0):
    radiance = np.asarray(radiance, np.float64)
    return SimpleNamespace(radiance=radiance,
                           stderr=np.full(radiance.shape[:2] + (3,), stderr, np.float32))


def test_error_image_zero_where_equal_and_grows_with_the_error():
    truth = _truth(np.ones((1, 9, 3)))
    mask = np.ones((1, 9), bool)
    # relative error d per pixel: image = truth * (1 + d), d from 0 to past ERROR_MAX
    d = np.array([0.0, 0.05, 0.1, 0.2, 0.25, 0.3, 0.4, ERROR_MAX, 2.0])
    out = error_image(truth.radiance * (1.0 + d)[None, :, None], truth, mask)
    assert out.dtype == np.uint8 and out.shape == (1, 9, 3)
    assert tuple(out[0, 0]) == (0, 0, 4)                   # the ramp's first colour: no error
    assert tuple(out[0, 2]) == (64, 15, 94)  # 0.1 = 0.2 ERROR_MAX: 0.4 of the way, ramp 1 to 2
    assert tuple(out[0, 7]) == tuple(out[0, 8]) == (252, 255, 164)  # ERROR_MAX and beyond: yellow
    brightness = out[0].astype(int).sum(-1)
    assert (np.diff(brightness) >= 0).all() and brightness[1] > brightness[0]
    # a darker image by the same relative amount gives the same colour (|.| of the difference)
    under = error_image(truth.radiance[:, :5] * (1.0 - d[:5])[None, :, None],
                        _truth(np.ones((1, 5, 3))), mask[:, :5])
    np.testing.assert_array_equal(under, out[:, :5])


def test_error_image_discounts_the_truth_noise_and_greys_the_mask():
    truth = _truth(np.full((2, 2, 4), 2.0), stderr=0.0625)
    mask = np.array([[True, True], [True, False]])
    # per channel: 0.125 = 2 stderr of difference is noise (-> 0); 0.325 -> (0.325 - 0.125) / 2
    image = truth.radiance[..., :3].copy()
    image[0, 0] += 0.125
    image[0, 1] += 0.325
    image[1, 0] -= 0.325
    image[1, 1] += 100.0
    out = error_image(image, truth, mask)
    assert tuple(out[0, 0]) == (0, 0, 4)
    assert tuple(out[0, 1]) == tuple(out[1, 0]) == (64, 15, 94)  # relative error 0.1
    assert tuple(out[1, 1]) == (64, 64, 64)  # not covered: grey whatever the error


# ---- composing ----------------------------------------------------------------------------------

def _tile(seed, h=10, w=12):
    return np.random.default_rng(seed).integers(0, 200, (h, w, 3), dtype=np.uint8)


def test_compose_size_and_tile_positions_without_labels():
    grid = [[_tile(0), _tile(1), _tile(2)], [_tile(3), None, _tile(5)]]
    img = compose(grid, ["a", "b", "c"], ["", ""])
    # left margin 8 (no row labels), top: one line of 13 px + 2 + 8, gap 2 between tiles
    left, top, gap = 8, 23, 2
    assert img.size == (left + 3 * (12 + gap), top + 2 * (10 + gap))
    px = np.asarray(img)
    for i, row in enumerate(grid):
        for j, tile in enumerate(row):
            y, x = top + i * (10 + gap), left + j * (12 + gap)
            cell = px[y:y + 10, x:x + 12]
            if tile is None:
                assert (cell == 255).all()
            else:
                np.testing.assert_array_equal(cell, tile)
    assert (px[top:, :left] == 255).all()   # no row labels: the left margin stays white
    assert (px[:top, left:] != 255).any()   # the column labels are drawn above the tiles


def test_compose_labels_scale_and_note():
    from PIL import Image, ImageDraw

    from relight.gallery.images import _font

    font_size = 11
    rows = ["park", "sky_conductor"]
    grid = [[_tile(10, 6, 8), _tile(11, 6, 8)], [_tile(12, 6, 8), _tile(13, 6, 8)]]
    img = compose(grid, ["a\nb", "x"], rows, scale=2, note="a note", font_size=font_size)
    measure = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    left = 8 + max(int(measure.textlength(s, font=_font(font_size))) for s in rows)
    top = 2 * (font_size + 2) + 8   # two lines in the tallest column label
    bottom = font_size + 10         # the note
    th, tw, gap = 12, 16, 2         # tiles drawn twice their size
    assert left > 8 + 20            # the longer row label widens the margin
    assert img.size == (left + 2 * (tw + gap), top + 2 * (th + gap) + bottom)
    px = np.asarray(img)
    for i in range(2):
        for j in range(2):
            y, x = top + i * (th + gap), left + j * (tw + gap)
            # nearest-neighbour upscaling: each source pixel becomes a 2 x 2 block
            np.testing.assert_array_equal(px[y:y + th, x:x + tw],
                                          grid[i][j].repeat(2, axis=0).repeat(2, axis=1))
            assert (px[y:y + th, 4:left - 2] != 255).any()  # the row's label beside it
    assert (px[-bottom:] != 255).any()        # the note under the grid
    assert (px[-bottom:, left + tw:] == 255).all()  # "a note" is short: right of it stays white


def test_compose_wraps_a_label_wider_than_its_tile():
    """A column label wider than its tile breaks at spaces into lines that fit (a word wider
    than the tile keeps a line of its own), and the label band grows by those lines: the
    gallery's long case names no longer run into each other."""
    from PIL import Image, ImageDraw

    from relight.gallery.images import _font, wrap_label

    font = _font(13)
    width = lambda t: ImageDraw.Draw(Image.new("RGB", (1, 1))).textlength(t, font=font)
    label = "ggx_split_sum + SSAO + indirect + shadow estimator"
    wrapped = wrap_label(label, 96, width)
    assert wrapped.replace("\n", " ") == label and wrapped.count("\n") >= 2
    assert all(width(line) <= 96 for line in wrapped.split("\n"))
    assert wrap_label("short", 96, width) == "short"
    assert wrap_label("averyveryverylongword x", 20, width) == "averyveryverylongword\nx"
    grid = [[_tile(1, 50, 100), _tile(2, 50, 100)]]
    one = compose(grid, ["a", "b"], [""], font_size=13)
    long = compose(grid, [label, "b"], [""], font_size=13)
    lines = wrap_label(label, 96, width).count("\n") + 1
    assert long.size[1] - one.size[1] == (lines - 1) * (13 + 2)
    assert long.size[0] == one.size[0]


# ---- report -------------------------------------------------------------------------------------

def _score_row(panel, scene, case, psnr, rel, bias, **extra):
    return {"scene": scene, "case": case, "bias_%": bias, "median_rel_%": rel, "psnr_db": psnr,
            "pixels": 100, "panel": panel, **extra}


def _report():
    rows = [
        _score_row("asset", "park", "blinn_phong", 30.14, 2.51, 1.24),
        _score_row("asset", "park", "neural", 28.0, 4.0, -3.06),
        _score_row("asset", "sky", "blinn_phong", 31.96, 1.0, 0.0),
    ] + [_score_row("spheres", f"s{k}", "unlit", 20.0 + k, 10.0, -1.0, truth_spp=4096)
         for k in range(5)]
    return {"command": "relight gallery --quick", "seconds": 12.3,
            "machine": {"gl_renderer": "llvmpipe", "gl_version": "4.5", "cpus": 2,
                        "platform": "Linux", "python": "3.11", "date": "2026-01-02 03:04:05"},
            "truth": {"park": {"spp": 512}, "sky": {"spp": 64}}, "error_max": ERROR_MAX,
            "cases": [{"label": c.label, "render": c.render} for c in CASES], "rows": rows}


def test_write_report_md_and_json_match_the_rows(tmp_path):
    report = _report()
    files = write_report(report, tmp_path)
    assert files == [tmp_path / "gallery.md", tmp_path / "gallery.json"]
    assert json.loads((tmp_path / "gallery.json").read_text()) == report
    md = (tmp_path / "gallery.md").read_text().splitlines()
    assert md[0] == ("Made by `relight gallery --quick` in 12 s on llvmpipe (2 CPUs, Linux), "
                     "2026-01-02 03:04:05.")
    assert any("64, 512 spp" in line for line in md)  # every truth's spp, sorted
    tables = [i for i, line in enumerate(md) if line.startswith("| case |")]
    assert [md[i] for i in tables] == ["| case | park | sky |", "| case | s0 | s1 | s2 |",
                                       "| case | s3 | s4 |"]  # the spheres split in halves
    asset = md[tables[0] + 2:tables[0] + 2 + len(CASES)]
    assert [line.split(" | ")[0] for line in asset] == [f"| `{c.label}`" for c in CASES]
    by_case = {line.split("`")[1]: line for line in asset}
    assert by_case["blinn_phong"] == "| `blinn_phong` | 30.1 / 2.5 / +1.2 | 32.0 / 1.0 / +0.0 |"
    assert by_case["neural"] == "| `neural` | 28.0 / 4.0 / -3.1 |  |"  # no sky row: blank
    assert by_case["unlit"] == "| `unlit` |  |  |"
    assert md[tables[2] + 2] == "| `unlit` | 23.0 / 10.0 / -1.0 | 24.0 / 10.0 / -1.0 |"


def test_write_report_without_a_panel(tmp_path):
    report = _report()
    report["rows"] = [r for r in report["rows"] if r["panel"] == "asset"]
    write_report(report, tmp_path)
    md = (tmp_path / "gallery.md").read_text()
    assert "glTF asset" in md and "fidelity scenes" not in md and md.count("| case |") == 1


# ---- command line -------------------------------------------------------------------------------

def test_parser_accepts_its_options(tmp_path, monkeypatch, capsys):
    args = build_parser().parse_args(["gallery", "--out", str(tmp_path / "g"), "--cache",
                                      str(tmp_path / "c"), "--spp", "8", "--size", "32x24",
                                      "--quick", "--no-spheres", "-q"])
    assert args.func is gallery.cmd_gallery
    assert (args.spp, args.size, args.quick, args.no_spheres, args.quiet) == (8, "32x24", True,
                                                                             True, True)
    defaults = build_parser().parse_args(["gallery"])
    assert (defaults.out, defaults.cache, defaults.spp, defaults.size) == (
        gallery.DEFAULT_OUT, gallery.DEFAULT_CACHE, 512, None)
    assert not (defaults.quick or defaults.no_spheres or defaults.quiet)

    seen = []
    monkeypatch.setattr(gallery, "run_gallery", lambda options, command: seen.append(options)
                        or {"files": ["a", "b"], "seconds": 3.0})
    assert main(["gallery", "--out", str(tmp_path / "g"), "--cache", str(tmp_path / "c"),
                 "--spp", "8", "--size", "32x24", "--no-spheres"]) == 0
    assert seen == [gallery.GalleryOptions(out=tmp_path / "g", cache=tmp_path / "c",
                                           size=(32, 24), spp=8, quick=False, spheres=False,
                                           progress=True)]
    assert capsys.readouterr().out == f"gallery: 2 files in {tmp_path / 'g'} (3 s)\n"


@pytest.mark.parametrize("args, needle", [
    (["--size", "12by3"], "--size must look like 512x512, got '12by3'"),
    (["--size", "0x10"], "--size 0x10 is outside 1..16384"),
    (["--spp", "0"], "--spp must be at least 1"),
])
def test_bad_options_one_line_exit_2(tmp_path, monkeypatch, capsys, args, needle):
    monkeypatch.setattr(gallery, "run_gallery", lambda *a, **k: pytest.fail("ran"))
    out = tmp_path / "g"
    assert main(["gallery", "--out", str(out), "--cache", str(tmp_path / "c"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("relight: error:") and needle in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_out_a_file_and_missing_mitsuba_are_one_line_errors(tmp_path, monkeypatch, capsys):
    a_file = tmp_path / "f.png"
    a_file.write_bytes(b"")
    assert main(["gallery", "--out", str(a_file)]) == 2
    err = capsys.readouterr().err.strip()
    assert "--out must be a folder" in err and "\n" not in err

    def no_mitsuba(options, command):
        raise ImportError("No module named 'mitsuba'")

    monkeypatch.setattr(gallery, "run_gallery", no_mitsuba)
    assert main(["gallery", "--out", str(tmp_path / "g"), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("relight: error:") and "needs Mitsuba 3" in err and "\n" not in err
