"""The gallery's numbers: ``gallery.md`` (a table of scores per panel, the command, the machine)
and ``gallery.json`` (the whole report)."""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

from .cases import CASES


def _machine(renderer) -> dict:
    from viewer.gl import gl_info

    info = gl_info(renderer.ctx)
    return {"gl_renderer": info.get("renderer"), "gl_version": info.get("version"),
            "cpus": os.cpu_count(), "platform": platform.platform(),
            "python": sys.version.split()[0], "date": time.strftime("%Y-%m-%d %H:%M:%S")}


def _table(rows: list[dict], scenes: list[str]) -> list[str]:
    lines = ["| case | " + " | ".join(scenes) + " |", "|---|" + "---|" * len(scenes)]
    by = {(r["scene"], r["case"]): r for r in rows}
    for case in CASES:
        cells = []
        for s in scenes:
            r = by.get((s, case.label))
            cells.append("" if r is None else
                         f"{r['psnr_db']:.1f} / {r['median_rel_%']:.1f} / {r['bias_%']:+.1f}")
        lines.append(f"| `{case.label}` | " + " | ".join(cells) + " |")
    return lines


def write_report(report: dict, out: Path) -> list[Path]:
    """``gallery.json`` (everything) and ``gallery.md`` (the tables, the command, the machine)."""
    m = report["machine"]
    md = [f"Made by `{report['command']}` in {report['seconds']:.0f} s on {m['gl_renderer']} "
          f"({m['cpus']} CPUs, {m['platform']}), {m['date']}.", ""]
    asset = [r for r in report["rows"] if r["panel"] == "asset"]
    if asset:
        envs = list(dict.fromkeys(r["scene"] for r in asset))
        spps = sorted({t["spp"] for t in report["truth"].values()})
        md += ["**The glTF asset** (`assets/scenes/gallery.toml`) against its path-traced truth "
               f"(Mitsuba 3, our BSDF, {', '.join(map(str, spps))} spp, path depth 6). Each cell: "
               "PSNR dB / median per-pixel relative error % / energy bias % over the pixels "
               "geometry covers (`relight.reference.compare.score`).", ""]
        md += _table(asset, envs) + [""]
    spheres = [r for r in report["rows"] if r["panel"] == "spheres"]
    if spheres:
        scenes = list(dict.fromkeys(r["scene"] for r in spheres))
        md += ["**The fidelity scenes** (`assets/scenes/reference`, 64 x 64) against their stored "
               "4,096-spp references (`assets/references`); the same three numbers. These scenes "
               "trace the multiple-scattering BSDF, as every truth here does.", ""]
        half = (len(scenes) + 1) // 2
        for part in (scenes[:half], scenes[half:]):
            if part:
                md += _table(spheres, part) + [""]
    (out / "gallery.md").write_text("\n".join(md))
    (out / "gallery.json").write_text(json.dumps(report, indent=1) + "\n")
    return [out / "gallery.md", out / "gallery.json"]
