"""``relight bench``'s reports: ``bench.json``, ``bench.csv``, ``bench.md`` (the results table with
the Pareto front marked, the tables against truth, specialisation and every extra suite) and
``pareto.png``, which ``python -m relight.bench.report BENCH.json PARETO.png`` redraws from a
``bench.json`` without measuring again."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from .suites import SUITES
from .truth import TRUTH_KEYS, truth_front, truth_summary

RESULT_KEYS = ("scene", "model", "variant", "samples", "size", "ms", "psnr", "ssim", "flip")
CSV_KEYS = RESULT_KEYS + ("kind", "group") + TRUTH_KEYS


def pareto_front(rows: list[dict]) -> list[dict]:
    """Rows not dominated in (lower ms, higher PSNR), per scene and size, sorted by time."""
    front = []
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r.get("kind") == "truth":  # their fronts: relight.bench.truth.truth_front
            continue
        if math.isfinite(r.get("ms", float("nan"))) and math.isfinite(r.get("psnr", float("nan"))):
            groups.setdefault((r["scene"], tuple(r["size"])), []).append(r)
    for group in groups.values():
        best = -math.inf
        for r in sorted(group, key=lambda r: (r["ms"], -r["psnr"])):
            if r["psnr"] > best:
                front.append(r)
                best = r["psnr"]
    return front


def _fmt(v) -> str:
    if v is None:  # a reading that does not exist (e.g. the rays' PSNR below one frame's cost)
        return "–"
    if isinstance(v, float):
        if math.isnan(v):
            return "–"
        if math.isinf(v):
            return "∞"
        return f"{v:.4g}"
    if isinstance(v, (list, tuple)):
        return "x".join(str(x) for x in v)
    return str(v)


def _pct(v, signed: bool = False) -> str:
    if not isinstance(v, (int, float)) or not math.isfinite(v):
        return "–"
    return f"{100 * v:+.1f}" if signed else f"{100 * v:.1f}"


def _truth_tables(rows: list[dict]) -> list[str]:
    """bench.md's section against truth: per-case summaries (all reference scenes, then each
    group) with the Pareto fronts marked, then every row."""
    truth = [r for r in rows if r.get("kind") == "truth"]
    if not truth:
        return []
    intro = ("Every mesh case on the reference scenes (`assets/scenes/reference`, at the "
             "references' size), scored with `relight.reference.compare.score` against the "
             "path-traced reference (**truth**: Mitsuba 3, our BSDF, visibility and "
             "inter-reflection) and against a converged `ggx_mc` of the same scene (**mc**: the "
             "same integrand, no visibility). Median relative error and |bias| in %, means over "
             "scenes; worst bias signed; PSNR in dB (peak = the reference's 99.9th percentile); "
             "time ratio = median over scenes of ms / `ggx_split_sum` single-scatter's ms. "
             "★ / ☆: Pareto front in (time, median error) against truth / against mc.")
    lines = ["", "### against truth", "", intro]
    groups = [("all reference scenes", None)] + [
        (f"{g} scenes", g) for g in sorted({r.get("group") for r in truth if r.get("group")})]
    for title, group in groups:
        summary = truth_summary(rows, group)
        scenes = sorted({r["scene"] for r in truth if group is None or r.get("group") == group})
        ft = {(e["model"], e["variant"]) for e in truth_front(summary, "truth")}
        fm = {(e["model"], e["variant"]) for e in truth_front(summary, "mc")}
        head = ("| model | variant | ms | time ratio | truth: median rel % | truth: abs bias % "
                "| truth: worst bias % | truth: PSNR | mc: median rel % | mc: abs bias % "
                "| mc: PSNR | pareto |")
        lines += ["", f"**{title}** ({', '.join(scenes)})", "", head, "|" + "---|" * 12]
        for e in summary:
            k = (e["model"], e["variant"])
            lines.append(
                f"| {e['model']} | {e['variant']} | {_fmt(e['ms'])} | {_fmt(e['ms_ratio'])} "
                f"| {_pct(e['median_rel_truth'])} | {_pct(e['abs_bias_truth'])} "
                f"| {_pct(e['worst_bias_truth'], True)} | {_fmt(e['psnr_truth'])} "
                f"| {_pct(e['median_rel_mc'])} | {_pct(e['abs_bias_mc'])} | {_fmt(e['psnr_mc'])} "
                f"| {'★' if k in ft else ''}{'☆' if k in fm else ''} |")
    head = ("| scene | model | variant | samples | size | ms | truth: median rel % "
            "| truth: bias % | truth: PSNR | mc: median rel % | mc: bias % | mc: PSNR |")
    lines += ["", "Every row:", "", head, "|" + "---|" * 12]
    for r in truth:
        lines.append(
            f"| {r['scene']} | {r['model']} | {r['variant']} | {r['samples']} | {_fmt(r['size'])} "
            f"| {_fmt(r.get('ms', math.nan))} | {_pct(r.get('median_rel_truth'))} "
            f"| {_pct(r.get('bias_truth'), True)} | {_fmt(r.get('psnr_truth', math.nan))} "
            f"| {_pct(r.get('median_rel_mc'))} | {_pct(r.get('bias_mc'), True)} "
            f"| {_fmt(r.get('psnr_mc', math.nan))} |")
    return lines


def suite_table(section: list[dict]) -> list[str]:
    """An extra suite's rows as markdown table lines (the union of their plain keys)."""
    keys = list(dict.fromkeys(k for r in section for k in r if not isinstance(r[k], dict)))
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in section:
        lines.append("| " + " | ".join(_fmt(r.get(k, "")) for k in keys) + " |")
    return lines


def write_reports(out: Path, report: dict) -> None:
    rows = report["results"]
    if any(r.get("kind") == "truth" for r in rows):
        groups = sorted({r.get("group") for r in rows if r.get("kind") == "truth"} - {None})
        report = {**report, "truth_summary": {g or "all": truth_summary(rows, g)
                                              for g in [None, *groups]}}
    (out / "bench.json").write_text(json.dumps(report, indent=1, allow_nan=True))
    with open(out / "bench.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(CSV_KEYS)
        for r in rows:
            w.writerow([_fmt(r.get(k, "")) for k in CSV_KEYS])
    front = {id(r) for r in pareto_front(rows)}
    lines = ["| " + " | ".join(RESULT_KEYS) + " | pareto |",
             "|" + "---|" * (len(RESULT_KEYS) + 1)]
    for r in rows:
        if r.get("kind") == "truth":
            continue
        lines.append("| " + " | ".join(_fmt(r.get(k, float("nan"))) for k in RESULT_KEYS)
                     + f" | {'★' if id(r) in front else ''} |")
    lines += _truth_tables(rows)
    if report.get("specialization"):
        lines += ["", "| scene | ms general | ms specialized | speed-up | max abs diff |",
                  "|---|---|---|---|---|"]
        for s in report["specialization"]:
            lines.append(f"| {s['scene']} | {_fmt(s['ms_general'])} | {_fmt(s['ms_specialized'])} "
                         f"| {_fmt(s['ms_general'] / s['ms_specialized'])}× "
                         f"| {_fmt(s['max_abs_diff'])} |")
    for name in SUITES:
        if report.get(name):
            lines += ["", f"### {name}", "", *suite_table(report[name])]
    m = report["machine"]
    header = (f"Measured on {m['gl'].get('renderer')} ({m['cpus']} CPUs, {m['platform']}), "
              f"{m['date']}. Times: median ms per frame; PSNR/SSIM on the display image and "
              f"HDR-FLIP on linear radiance against a converged `ggx_mc` reference.\n\n")
    (out / "bench.md").write_text(header + "\n".join(lines) + "\n")
    _plot(out / "pareto.png", rows)


def _plot(path: Path, rows: list[dict]) -> None:
    """Write :func:`pareto_figure` to ``path`` (nothing without matplotlib: tables only)."""
    fig = pareto_figure(rows)
    if fig is None:
        return
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=fig.dpi)  # the dpi the labels were placed at
    plt.close(fig)


def redraw(bench_json: str | Path, png: str | Path) -> None:
    """Draw ``pareto.png`` again from a ``bench.json`` (its ``results``), without measuring:
    ``python -m relight.bench.report assets/bench/bench.json assets/bench/pareto.png``."""
    _plot(Path(png), json.loads(Path(bench_json).read_text())["results"])


def pareto_figure(rows: list[dict]):
    """pareto.png's figure (None without matplotlib or points): a panel per bench scene (PSNR vs
    converged ``ggx_mc`` against time) and, with truth rows, a second row of two panels over the
    reference scenes: mean median relative error against the path-traced reference and against
    converged ``ggx_mc``, against time, each Pareto-front point labelled where no label overlaps
    another or the legend (:func:`relight.bench.labels.place_labels`)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # the bench extra is not installed: tables only
        return None
    from .labels import place_labels

    pts = [r for r in rows if r.get("kind") != "truth" and math.isfinite(r.get("ms", math.nan))
           and math.isfinite(r.get("psnr", math.nan))]
    summary = [e for e in truth_summary(rows) if math.isfinite(e["ms"])]
    if not pts and not summary:
        return None
    scenes = sorted({(r["scene"], tuple(r["size"])) for r in pts})
    ncols = max(len(scenes), 2 if summary else 1)
    nrows = int(bool(scenes)) + int(bool(summary))
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.5 * ncols, 4.5 * nrows), squeeze=False,
                             dpi=110)
    models = sorted({r["model"] for r in pts} | {e["model"] for e in summary})
    colours = {m: plt.cm.tab10(i % 10) for i, m in enumerate(models)}
    front = {id(r) for r in pareto_front(rows)}
    for ax, (sname, size) in zip(axes[0], scenes):
        group = [r for r in pts if r["scene"] == sname and tuple(r["size"]) == size]
        for m in models:
            g = [r for r in group if r["model"] == m]
            if g:
                ax.scatter([r["ms"] for r in g], [r["psnr"] for r in g], color=colours[m],
                           label=m, s=22)
        f = sorted((r for r in group if id(r) in front), key=lambda r: r["ms"])
        ax.plot([r["ms"] for r in f], [r["psnr"] for r in f], "k--", lw=0.8, label="Pareto front")
        ax.set_xscale("log")
        ax.set_xlabel("ms per frame (log)")
        ax.set_ylabel("PSNR vs converged ggx_mc (dB)")
        ax.set_title(f"{sname} {size[0]}x{size[1]}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    labelled = []  # (axes, points, labels): placed once the layout is final
    if summary:
        n = len({r["scene"] for r in rows if r.get("kind") == "truth"})
        titles = {"truth": f"vs path-traced reference (visibility), mean of {n} scenes",
                  "mc": f"vs converged ggx_mc (same integrand), mean of {n} scenes"}
        for ax, ref in zip(axes[-1], ("truth", "mc")):
            good = [e for e in summary if math.isfinite(e[f"median_rel_{ref}"])
                    and e[f"median_rel_{ref}"] > 0]
            for m in models:
                g = [e for e in good if e["model"] == m]
                if g:
                    ax.scatter([e["ms"] for e in g], [100 * e[f"median_rel_{ref}"] for e in g],
                               color=colours[m], label=m, s=22)
            f = [e for e in truth_front(good, ref)]
            ax.plot([e["ms"] for e in f], [100 * e[f"median_rel_{ref}"] for e in f], "k--",
                    lw=0.8, label="Pareto front")
            labelled.append((ax, [(e["ms"], 100 * e[f"median_rel_{ref}"]) for e in f],
                             [e["model"] + ("" if e["variant"] == "default"
                                            else f" {e['variant']}") for e in f]))
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("ms per frame (log), median over scenes")
            ax.set_ylabel("median relative error (%, log)")
            ax.set_title(titles[ref], fontsize=10)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        for ax in axes[-1][2:]:
            ax.axis("off")
    for ax in axes[0][len(scenes):] if scenes else []:
        ax.axis("off")
    fig.tight_layout()
    fig.canvas.draw()  # the layout and the legends' "best" places, final before labels go in
    for ax, points, labels in labelled:
        legend = ax.get_legend()
        box = legend.get_window_extent()
        # pin the legend where "best" put it: it would move away from the labels otherwise
        legend.set_loc(tuple(ax.transAxes.inverted().transform((box.x0, box.y0))))
        place_labels(ax, points, labels, fontsize=6, avoid=[box])
    return fig


if __name__ == "__main__":  # python -m relight.bench.report BENCH.json PARETO.png
    import sys

    redraw(*sys.argv[1:3])
