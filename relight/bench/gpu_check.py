"""One command that measures a machine lent for a short while (a GPU server) and leaves the
tables behind: ``python -m relight.bench.gpu_check --out DIR``.

Steps, in order of what matters most, each a ``relight`` process of its own (a crash or a hang in
one does not lose the others), each given what is left of ``--budget`` seconds (480 by default;
a step that runs out is stopped and recorded, the steps after it are recorded as not run):

1. ``info``: ``relight info``, printed first and saved (``info.txt``, ``info.json``), so every
   number after it carries the card's name;
2. ``parity``: ``relight parity --json`` -> ``parity.json`` (exit status 1 when a check fails:
   recorded, the check goes on);
3. ``path``: ``relight bench --suite path --quick`` -> ``bench/path.md``, ``bench/path.json``
   (the path tracer against truth, beside Mitsuba, the BVH: :mod:`relight.bench.path`);
4. ``suites``: ``relight bench --quick`` with the GPU-bound extra suites ``mc_convergence``,
   ``shadows``, ``antialias``, ``splats``, ``neural``, ``clamps`` -> ``bench/<suite>.md``;
5. ``main``: ``relight bench --quick`` -> ``bench/bench.md`` (every model's frame time and error,
   against truth too, ``pareto.png``). It reuses the suites measured above (``relight bench``
   resumes finished suites); the CPU-bound or minutes-long ones (:data:`LEFT_OUT`: held-out
   data, environments, memory, shadow_truth, penumbra, splat_decomp) are written empty first,
   so it does not measure them.

``summary.md`` / ``summary.json`` in ``DIR``: the renderer string, each step's command, exit
status, seconds and outputs, the parity tally. Exit status 0 when every step ran and exited 0.
``--steps info,path`` runs a subset; ``--software`` forces llvmpipe (``RELIGHT_SOFTWARE_GL=1``),
which is how the command is checked without a GPU (slower: give it a larger ``--budget``).
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

SUITES = ("mc_convergence", "shadows", "antialias", "splats", "neural", "clamps")
# relight bench's suites the main step leaves out: CPU-bound (Mitsuba, torch training, new
# processes) or minutes long; their results do not depend on the GPU much
LEFT_OUT = ("heldout", "environments", "memory", "shadow_truth", "penumbra", "splat_decomp")
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
            for suite in LEFT_OUT:  # relight bench resumes finished suites: these count as done
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
        elif name == "parity":
            entry["parity"] = _parity_tally(out / "parity.json")
        entry["outputs"] = _outputs(out, name)
        print(f"gpu_check: {name}: {entry['status']} in {entry['seconds']} s "
              f"({entry['command']})", flush=True)
    summary["complete"] = all(e["status"] == "ok" for e in summary["steps"])
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    (out / "summary.md").write_text(summary_markdown(summary))
    return summary


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
