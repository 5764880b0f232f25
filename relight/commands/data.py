"""``relight data``: (re)generate a named dataset (:mod:`learned.data.presets`)."""
from __future__ import annotations

from viewer.errors import RelightError

from .reference import reference_tracer


def _data_config(args):
    """``relight data``'s configuration: ``--preset`` with ``--count``, ``--size``, ``--spp``,
    ``--seed``, ``--sunless`` and ``--ground`` overriding its fields (none given: exactly the preset's
    dataset)."""
    try:
        from learned.data.presets import preset_config
    except ImportError as exc:
        raise RelightError(f"relight data needs the 'reference' extra: pip install -e "
                           f"'.[reference]' ({exc})", where="data") from None
    return preset_config(args.preset, count=args.count, size=args.size, reference_spp=args.spp,
                         seed=args.seed, sunless_fraction=getattr(args, "sunless", None),
                         ground_fraction=getattr(args, "ground", None))


def _protocol_data(args) -> int:
    """``relight data OUT --protocol``: the protocol's dataset (:mod:`learned.protocol.data`):
    ``--count`` train samples (default 120), a quarter of them val and two fifths test."""
    from learned.protocol.data import DEFAULT_COUNTS, generate_protocol, protocol_configs

    counts = DEFAULT_COUNTS
    if args.count is not None:
        counts = {"train": args.count, "val": max(1, args.count // 4),
                  "test": max(1, (2 * args.count) // 5)}
    configs = protocol_configs(counts, size=args.size or 64, reference_spp=args.spp or 256,
                               seed=100 if args.seed is None else args.seed)
    tracer = reference_tracer(where="relight data")
    generate_protocol(args.out, configs, tracer=tracer, progress=not args.quiet)
    if not args.quiet:
        print(f"{args.out}: protocol dataset, "
              + ", ".join(f"{s} {c.count} (seed {c.seed}, "
                          f"{', '.join((*c.env_procedural, *c.env_paths))})"
                          for s, c in configs.items()))
        print(f"next: relight eval {args.out} --protocol [--degrade 0.5]")
    return 0


def cmd_data(args) -> int:
    """(Re)generate a named dataset (:mod:`learned.data.presets`: the path-traced training truth
    and the two held-out sets) under OUT: resumable (finished samples are kept, an interrupted
    path-traced target resumes from its checkpoint), sharded over torchrun ranks (sample i by
    rank i % WORLD_SIZE, every rank returning once all are written)."""
    from learned.data.generator import generate, split_of
    from learned.data.presets import PRESETS

    if getattr(args, "protocol", False):
        if args.preset:
            raise RelightError("--protocol and --preset are two datasets: give one",
                               where="--preset")
        return _protocol_data(args)
    if not args.preset:
        raise RelightError("give --preset NAME or --protocol", where="relight data")

    config = _data_config(args)  # checked before Mitsuba loads or anything is written
    tracer = reference_tracer(where="relight data")
    out = generate(args.out, config, progress=not args.quiet, shard=True, tracer=tracer)
    if args.quiet or out.get("rank", 0) != 0:
        return 0
    preset = PRESETS[args.preset]()
    splits = {s: sum(split_of(i, config) == s for i in range(config.count))
              for s in ("train", "val", "test")}
    by = " by rank 0" if "rank" in out else ""
    print(f"{args.out}: preset {args.preset}, {config.count} samples "
          f"({', '.join(f'{n} {s}' for s, n in splits.items() if n)}; {out['written']} written, "
          f"{out['kept']} kept{by}), {config.size}x{config.size}, {config.reference_spp} spp "
          "path-traced")
    options = (("size", "size"), ("spp", "reference_spp"), ("seed", "seed"))
    changed = [f"--{o} {getattr(config, k)}" for o, k in options
               if getattr(config, k) != getattr(preset, k)]
    if changed:
        print(f"  {', '.join(changed)}: not the preset's dataset (its scores are not comparable "
              "with the README's)")
    elif config.count < preset.count:
        print(f"  --count {config.count}: the first {config.count} of the preset's "
              f"{preset.count} samples")
    elif config.count > preset.count:
        print(f"  --count {config.count}: the preset's {preset.count} samples and "
              f"{config.count - preset.count} more")
    if args.preset == "truth-train":
        print(f"next: relight train --data {args.out} --student-target target ... "
              f"(assets/weights/README.md); relight eval {args.out} --split test")
    elif args.preset in ("shadow-extra", "shadow-val"):
        flag = "extra" if args.preset == "shadow-extra" else "val"
        print(f"next: relight train --stage shadow_net --data PROTOCOL_DATA "
              f"--shadow-{flag}-data {args.out}")
    else:
        print(f"next: relight eval {args.out} --split all")
        print(f"      relight bench --out runs/bench --heldout {args.out}")
    return 0
