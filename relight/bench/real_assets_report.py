"""The report of :mod:`relight.bench.real_assets`: the failures counted per judged case, the
markdown table and the files (``real_assets.json``, ``.md``, the contact sheets)."""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

# the HDRI of the small sheet: where the student's screen-space speckle was worst (issue 36)
SHEET_ENV = "lobby"


def machine_info(renderer) -> dict:
    """Where it ran (not :func:`relight.bench.run.machine_info`: run imports the suites, which
    import the bench)."""
    from viewer.gl import gl_info

    return {"gl": {k: v for k, v in gl_info(renderer.ctx).items() if k != "extensions"},
            "cpus": os.cpu_count(), "platform": platform.platform(),
            "python": sys.version.split()[0], "date": time.strftime("%Y-%m-%d %H:%M:%S")}


def summary(rows: list[dict]) -> dict:
    """Failures per judged case and condition, and the rows judged."""
    out: dict = {}
    for r in rows:
        if "baseline" not in r:
            continue
        key = r["case"] + (" (splats)" if r.get("geometry") == "splats" else "")
        s = out.setdefault(key, {"rows": 0, "speckle": 0, "shadow": 0, "psnr": 0,
                                       "failed_rows": 0, "psnr_gain_db": []})
        s["rows"] += 1
        s["psnr_gain_db"].append(r["psnr_gain_db"])
        for k in ("speckle", "shadow", "psnr"):
            s[k] += not r[f"{k}_ok"]
        s["failed_rows"] += not r["ok"]
    for s in out.values():  # PSNR against the baseline's: mean and worst over the rows
        gains = s.pop("psnr_gain_db")
        s["psnr_gain_mean_db"] = round(sum(gains) / len(gains), 2)
        s["psnr_gain_min_db"] = min(gains)
    return out


def summary_line(summary_: dict) -> str:
    return "; ".join(f"{case}: {s['failed_rows']} of {s['rows']} scenes fail (speckle "
                     f"{s['speckle']}, invented shadow {s['shadow']}, PSNR {s['psnr']}; PSNR "
                     f"{s['psnr_gain_mean_db']:+.2f} dB on average against its baseline, at "
                     f"worst {s['psnr_gain_min_db']:+.2f})"
                     for case, s in summary_.items())


def markdown(report: dict) -> str:
    t = report["tolerances"]
    m = report["machine"]
    made = (f"Made by `{report['command']}` in {report['seconds']:.0f} s on "
            f"{m['gl'].get('renderer')} ({m['cpus']} CPUs), {m['date']}; "
            f"{report['size'][0]}x{report['size'][1]}, truth {report['spp']} spp "
            "(Mitsuba 3, our BSDF, depth 6), traced in "
            f"{sum(v['seconds'] or 0 for v in report['truth'].values()):.0f} s when first made "
            "(then cached: a second run only rasterises).")
    rule = (f"Verdict per judged row (against split-sum with the same visibility): speckle "
            f"<= {t['speckle_ratio']} x split-sum's; invented shadow < "
            f"{100 * t['invented_shadow']:g} % of the covered pixels (darker than split-sum by "
            f"> {100 * (1 - t['model_darker']):g} % where the truth is not darker by > "
            f"{100 * (1 - t['truth_darker']):g} %, 3x3-blurred); PSNR >= split-sum's - "
            f"{t['psnr_db']} dB.")
    head = ("| scene | case | PSNR dB | median rel % | bias % | floor speckle (reference, "
            "split-sum) | differs from split-sum % | invented shadow % | verdict |")
    lines = [made, "", rule, "", f"**{summary_line(report['summary'])}**", "", head,
             "|---|---|---|---|---|---|---|---|---|"]
    for r in report["rows"]:
        sp = f"{r['speckle']:.4f} ({r['speckle_reference']:.4f}"
        sp += f", {r['speckle_baseline']:.4f})" if "speckle_baseline" in r else ")"
        verdict_ = "" if "ok" not in r else ("ok" if r["ok"] else "FAIL: " + ", ".join(
            k for k in ("speckle", "shadow", "psnr") if not r[f"{k}_ok"]))
        lines.append(f"| {r['scene']} | {r['case']} | {r['psnr_db']:.2f} | "
                     f"{r['median_rel_%']:.1f} | {r['bias_%']:+.1f} | {sp} | "
                     f"{r.get('differs_%', '')} | {r.get('invented_shadow_%', '')} | "
                     f"{verdict_} |")
    return "\n".join(lines) + "\n"


def write(report: dict, sheet: list, out: Path, labels: list[str]) -> list[Path]:
    """``real_assets.json``, ``real_assets.md``, the contact sheet ``real_assets.png`` (a row per
    scene, the reference then every case) and ``real_assets_lobby.png`` (the scenes under
    :data:`SHEET_ENV` alone: small enough for the documentation), at the render's size in the
    gallery's display transform, saved as RGB (not the gallery's dithered palette, whose dither
    would read as speckle)."""
    from relight.gallery.images import compose

    (out / "real_assets.json").write_text(json.dumps(report, indent=1) + "\n")
    (out / "real_assets.md").write_text(markdown(report))
    files = [out / "real_assets.json", out / "real_assets.md"]
    cols = ["reference"] + labels
    note = f"truth: Mitsuba 3, {report['spp']} spp; display: exposure 0, ACES, sRGB"
    for path, part in ((out / "real_assets.png", sheet),
                       (out / f"real_assets_{SHEET_ENV}.png",
                        [(n, t) for n, t in sheet if n.endswith(f"/{SHEET_ENV}")])):
        if part:
            img = compose([[tiles.get(c) for c in cols] for _, tiles in part],
                          [c.replace(", ", ",\n") for c in cols], [n for n, _ in part], note=note)
            img.save(path, optimize=True)
            files.append(path)
    return files
