"""``relight bench``: the benchmark (:mod:`relight.bench`) and its summary on stdout."""
from __future__ import annotations


def cmd_bench(args) -> int:
    from ..bench.run import BenchConfig, pareto_front, run_bench

    config = BenchConfig(quick=args.quick, frames=args.frames,
                         reference_spp=256 if args.quick else 1024,
                         heldout=tuple(getattr(args, "heldout", None) or ()),
                         trade=tuple(getattr(args, "trade", None) or ()))
    if getattr(args, "suite", None):
        from ..bench.report import suite_table
        from ..bench.run import run_suites

        for name, rows in run_suites(args.out, args.suite, config,
                                     progress=not args.quiet).items():
            print(f"{name} ({args.out}/{name}.json, {name}.md):")
            print("\n".join(suite_table(rows)) if rows else "  (no rows)")
        return 0
    report = run_bench(args.out, config, fresh=args.fresh, progress=not args.quiet)
    front = pareto_front(report["results"])
    print(f"wrote {args.out}/bench.json, bench.csv, bench.md, pareto.png "
          f"({len(report['results'])} rows)")
    print("Pareto front (fastest first, each more accurate than the previous):")
    for r in front:
        print(f"  {r['scene']:>8} {r['size'][0]}x{r['size'][1]}  {r['model']:<14} "
              f"{r['variant']:<22} {r['ms']:9.2f} ms  {r['psnr']:6.2f} dB")
    for s in report["specialization"]:
        print(f"specialised {s['scene']}: {s['ms_general']:.2f} -> {s['ms_specialized']:.2f} ms "
              f"({s['ms_general'] / s['ms_specialized']:.2f}x), max abs diff {s['max_abs_diff']:.2g}")
    from ..bench.truth import truth_front, truth_summary

    summary = truth_summary(report["results"])
    if summary:
        print("Against the path-traced references (mean over scenes; time relative to split-sum):")
        for ref, label in (("truth", "path-traced truth"), ("mc", "converged ggx_mc")):
            print(f"  Pareto front vs {label}:")
            for e in truth_front(summary, ref):
                print(f"    {e['model']:<14} {e['variant']:<24} {e['ms_ratio']:6.2f}x  median rel. "
                      f"error {100 * e[f'median_rel_{ref}']:5.1f} %  |bias| "
                      f"{100 * e[f'abs_bias_{ref}']:5.1f} %")
    if report.get("heldout"):
        print("Against path-traced truth on the held-out datasets (Pareto front, fastest first):")
        for r in report["heldout"]:
            if r["pareto"]:
                print(f"  {r['dataset']:<16} {r['model']:<14} {r['variant']:<26} {r['ms']:8.2f} ms "
                      f"{r['psnr']:6.2f} dB")
    return 0
