"""``relight parity``: the GLSL passes against their torch twins."""
from __future__ import annotations

import json

from viewer.errors import RelightError

from .common import _context_options


def cmd_parity(args) -> int:
    try:
        from learned.parity import run_parity
    except ImportError as exc:
        raise RelightError(f"relight parity needs torch: pip install -e '.[learned]' ({exc})",
                           where="parity") from None
    from viewer.gl import Programs, create_context
    from viewer.models import model_info

    from learned.parity import check_models, pass_checks

    unknown = [name for name in args.skip if name not in pass_checks()]
    if unknown:
        raise RelightError(f"no pass check named {unknown[0]!r} (known: "
                           f"{', '.join(pass_checks())})", where="--skip")
    if args.model is not None:

        if args.model not in check_models():
            model_info(args.model)  # not a pass-check group (e.g. "splats"): must be a model
    ctx = create_context(_context_options(args))
    try:
        results = run_parity(Programs(ctx), model=args.model, seed=args.seed,
                              skip=tuple(args.skip))
    finally:
        ctx.release()
    if args.json:
        print(json.dumps([r.as_json() for r in results], indent=1))
    else:
        width = max((len(r.name) for r in results), default=10)
        print(f"{'name':<{width}}  {'kind':<8} {'max_abs':>10} {'max_rel':>10}  tolerance")
        for r in results:
            flag = "ok  " if r.passed else "FAIL"
            print(f"{r.name:<{width}}  {r.kind:<8} {r.max_abs:10.3g} {r.max_rel:10.3g}  "
                  f"{r.tolerance}  {flag}")
        failed = sum(not r.passed for r in results)
        print(f"{len(results) - failed} passed, {failed} failed")
    return 0 if all(r.passed for r in results) else 1
