"""One command that measures a machine lent for a short while (a GPU server) and leaves the
tables behind: ``python -m relight.bench.gpu_check --out DIR``.

Steps, in order of what matters most, each a ``relight`` process of its own (a crash or a hang in
one does not lose the others), each given what is left of ``--budget`` seconds (480 by default;
a step that runs out is stopped and recorded, the steps after it are recorded as not run):

1. ``info``: ``relight info``, printed first and saved (``info.txt``, ``info.json``; the host's
   CPU count and platform in ``host.json``), so every
   number after it carries the card's name;
2. ``parity``: ``relight parity --json`` -> ``parity.json`` (exit status 1 when a check fails:
   recorded, the check goes on);
3. ``path``: ``relight bench --suite path --quick`` -> ``bench/path.md``, ``bench/path.json``
   (the path tracer against truth, beside Mitsuba, the BVH: :mod:`relight.bench.path`);
4. ``suites``: ``relight bench --quick`` with the GPU-bound extra suites (:data:`SUITES`:
   ``mc_convergence``, ``shadows``, ``antialias``, ``splats``, ``neural``, ``clamps``,
   ``shadow_net``, then ``rays``, the longest, last) -> ``bench/<suite>.md``, each written as it
   finishes;
5. ``main``: ``relight bench --quick`` -> ``bench/bench.md`` (every model's frame time and error,
   against truth too, ``pareto.png``). It reuses the suites measured above (``relight bench``
   resumes finished suites); the CPU-bound or minutes-long ones (:data:`LEFT_OUT`: held-out
   data, environments, memory, shadow_truth, penumbra, splat_decomp, real_assets) and any suite
   the ``suites`` step did not finish are written empty first (``summary.json`` lists the
   latter), so it does not measure them. If the step stops before its tables are written, the
   rows it measured (``bench/rows.jsonl``) are written as ``bench/bench.md`` anyway, headed as
   partial, with the card's name from ``info.json`` (:func:`partial_main_report`).

``summary.md`` / ``summary.json`` in ``DIR``: the renderer string, each step's command, exit
status, seconds and outputs, the parity tally. Exit status 0 when every step ran and exited 0.
``--steps info,path`` runs a subset; ``--software`` forces llvmpipe (``RELIGHT_SOFTWARE_GL=1``),
which is how the command is checked without a GPU (slower: give it a larger ``--budget``).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import subprocess
import sys
import time
from pathlib import Path

# the rays suite last: on an H200 (2026-11-28) it ran past 3 minutes inside the main step
SUITES = ("mc_convergence", "shadows", "antialias", "splats", "neural", "clamps", "shadow_net",
          "rays")
# relight bench's suites the main step leaves out: CPU-bound (Mitsuba, torch training, new
# processes) or minutes long, or needing a dataset (shadow_trade); their results do not depend
# on the GPU much
LEFT_OUT = ("heldout", "environments", "memory", "shadow_truth", "penumbra", "splat_decomp",
            "real_assets", "shadow_trade")
STEPS = ("info", "parity", "path", "suites", "main")
BUDGET_S = 480.0


def step_commands(out: Path) -> dict[str, list[str]]:
    """``relight`` arguments of every step (module docstring)."""
    bench = str(out / "bench")
    return {
        "info": ["info"],
        "parity": ["parity", "--json"],
        "path": ["bench", "--suite", "path", "--quick", "--out", bench],
        "suites": ["bench", *[a for s in SUITES for a in ("--suite", s)], "--quick",
                   "--out", bench],
        "main": ["bench", "--quick", "--out", bench],
    }


def _run(args: list[str], timeout: float, stdout, stderr, env) -> tuple[int | None, float]:
    """Run ``python -m relight ARGS`` in a session of its own; on timeout stop that session
    (the step and whatever it started). ``(exit status or None on timeout, seconds)``."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "relight", *args], stdout=stdout,
                            stderr=stderr, env=env, start_new_session=True)
    try:
        rc = proc.wait(timeout=max(timeout, 0.0))
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        rc = None
    return rc, time.perf_counter() - t0


def run_check(out: str | Path, budget: float = BUDGET_S, steps=STEPS,
              software: bool = False) -> dict:
    """Run ``steps`` within ``budget`` seconds, write ``summary.json`` / ``summary.md`` in
    ``out`` and return the summary."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "logs").mkdir(exist_ok=True)
    (out / "bench").mkdir(exist_ok=True)
    env = dict(os.environ)
    if software:
        env["RELIGHT_SOFTWARE_GL"] = "1"
    commands = step_commands(out)
    deadline = time.perf_counter() + budget
    summary = {"out": str(out), "budget_s": budget, "renderer": None, "steps": []}
    for name in STEPS:
        if name not in steps:
            continue
        args = commands[name]
        left = deadline - time.perf_counter()
        entry = {"step": name, "command": "relight " + " ".join(args), "rc": None,
                 "seconds": 0.0, "status": "not run (budget spent)"}
        summary["steps"].append(entry)
        if left <= 1.0:
            continue
        log = out / "logs" / f"{name}.log"
        if name == "main":
            # relight bench resumes finished suites: these count as done
            entry["suites_not_measured"] = [s for s in SUITES
                                            if not (out / "bench" / f"{s}.json").exists()]
            for suite in (*LEFT_OUT, *entry["suites_not_measured"]):
                path = out / "bench" / f"{suite}.json"
                if not path.exists():
                    path.write_text("[]\n")
        target = {"info": out / "info.txt", "parity": out / "parity.json"}.get(name)
        with open(log, "w") as err:
            if target is not None:
                with open(target, "w") as f:
                    rc, sec = _run(args, left, f, err, env)
            else:
                rc, sec = _run(args, left, err, subprocess.STDOUT, env)
        entry.update(rc=rc, seconds=round(sec, 1),
                     status="timed out" if rc is None else ("ok" if rc == 0 else f"exit {rc}"))
        if name == "info":
            text = (out / "info.txt").read_text()
            print(text, flush=True)  # the card's name first
            with open(out / "info.json", "w") as f:
                _run(["info", "--json"], 60, f, subprocess.DEVNULL, env)
            summary["renderer"] = _renderer(out / "info.json", text)
            (out / "host.json").write_text(json.dumps(
                {"cpus": os.cpu_count(), "platform": platform.platform()}))
        elif name == "parity":
            entry["parity"] = _parity_tally(out / "parity.json")
        elif name == "main" and rc != 0:
            entry["partial_rows"] = partial_main_report(out)
        entry["outputs"] = _outputs(out, name)
        print(f"gpu_check: {name}: {entry['status']} in {entry['seconds']} s "
              f"({entry['command']})", flush=True)
    summary["complete"] = all(e["status"] == "ok" for e in summary["steps"])
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    (out / "summary.md").write_text(summary_markdown(summary))
    return summary


def partial_main_report(out: str | Path) -> int:
    """Where the main step stopped before writing its tables (``bench/bench.md`` missing or
    older than ``bench/rows.jsonl``), write them from the rows it measured, with the machine
    read from ``info.json`` and a first line saying the table is partial. Returns the number of
    rows written (0: nothing to do)."""
    from .report import write_reports

    out = Path(out)
    rows_path, md = out / "bench" / "rows.jsonl", out / "bench" / "bench.md"
    if not rows_path.is_file() or (md.is_file()
                                   and md.stat().st_mtime >= rows_path.stat().st_mtime):
        return 0
    rows = [json.loads(line) for line in rows_path.read_text().splitlines() if line.strip()]
    if not rows:
        return 0
    info = {}
    for name in ("info.json", "host.json"):  # the card; the host's CPUs (the info step's)
        try:
            info.update(json.loads((out / name).read_text()))
        except (OSError, ValueError):
            pass
    machine = {"gl": {"renderer": info.get("renderer", "unknown renderer")},
               "cpus": info.get("cpus", "?"), "platform": info.get("platform", "?"),
               "date": time.strftime("%Y-%m-%d %H:%M:%S",
                                     time.localtime(rows_path.stat().st_mtime))}
    write_reports(out / "bench", {"machine": machine, "results": rows})
    md.write_text("**Partial**: the main step stopped before it finished; these are the "
                  f"{len(rows)} rows it had measured (`bench/rows.jsonl`), no extra suites.\n\n"
                  + md.read_text())
    return len(rows)


def _renderer(info_json: Path, text: str) -> str | None:
    try:
        return json.loads(info_json.read_text())["renderer"]
    except (OSError, ValueError, KeyError):
        for line in text.splitlines():
            if line.strip().startswith("renderer:"):
                return line.split(":", 1)[1].strip()
    return None


def _parity_tally(path: Path) -> dict | None:
    try:
        results = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    failed = [r["name"] for r in results if not r.get("passed")]
    return {"checks": len(results), "failed": len(failed), "failed_names": failed[:20]}


def _outputs(out: Path, name: str) -> list[str]:
    files = {"info": ["info.txt", "info.json"], "parity": ["parity.json"],
             "path": ["bench/path.md", "bench/path.json"],
             "suites": [f"bench/{s}.md" for s in SUITES],
             "main": ["bench/bench.md", "bench/bench.json", "bench/pareto.png"]}[name]
    return [f for f in files if (out / f).is_file() and (out / f).stat().st_size > 0]


def summary_markdown(summary: dict) -> str:
    lines = [(f"GPU check on **{summary['renderer']}**, budget {summary['budget_s']:.0f} s "
              f"({time.strftime('%Y-%m-%d %H:%M:%S')})."), "",
             "| step | status | seconds | command | outputs |", "|---|---|---|---|---|"]
    for e in summary["steps"]:
        extra = ""
        tally = e.get("parity")
        if tally:
            extra = f" ({tally['checks'] - tally['failed']}/{tally['checks']} parity checks pass)"
        lines.append(f"| {e['step']} | {e['status']}{extra} | {e['seconds']} | "
                     f"`{e['command']}` | {', '.join(e.get('outputs', []))} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m relight.bench.gpu_check",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="output folder (tables, logs, summary.md)")
    p.add_argument("--budget", type=float, default=BUDGET_S,
                   help=f"seconds for all steps together (default {BUDGET_S:.0f})")
    p.add_argument("--steps", default=",".join(STEPS),
                   help=f"comma-separated subset of {','.join(STEPS)} (default all)")
    p.add_argument("--software", action="store_true", help="force Mesa llvmpipe")
    args = p.parse_args(argv)
    steps = [s.strip() for s in args.steps.split(",") if s.strip()]
    unknown = [s for s in steps if s not in STEPS]
    if unknown:
        p.error(f"unknown step {unknown[0]!r} (known: {', '.join(STEPS)})")
    summary = run_check(args.out, args.budget, steps, args.software)
    print(summary_markdown(summary), end="")
    return 0 if summary["complete"] else 1


if __name__ == "__main__":
    sys.exit(main())
