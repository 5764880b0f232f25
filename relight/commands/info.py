"""``relight info``: the OpenGL context's renderer, version, limits and extensions."""
from __future__ import annotations

import json

from .common import _context_options


def cmd_info(args) -> int:
    from viewer.gl import create_context, gl_info

    ctx = create_context(_context_options(args))
    try:
        info = gl_info(ctx)
    finally:
        ctx.release()
    if args.json:
        print(json.dumps(info, indent=1))
        return 0
    exts = info.pop("extensions")
    for k, v in info.items():
        print(f"{k:>26}: {v}")
    print(f"{'extensions':>26}: {len(exts)} ({', '.join(exts[:6])}, ...)")
    return 0
