"""``frictionrt bench``: step-time benchmarks [us] of the compiled kernels (rt.loop.bench)."""
from __future__ import annotations

import argparse
import json

from rt.cli.common import fail


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``bench`` (parents: frictionrt's --config/--set parser)."""
    b = sub.add_parser("bench", parents=parents, help="step-time benchmarks [us]",
                       description="Per-step wall time [us] of the compiled kernels: median, p99, p99.9, max.")
    b.add_argument("target", choices=["plant", "loop"],
                   help="plant: the Newmark/Newton step for 5, 9, 17, 33 pairs; loop: the whole tick and the "
                        "controller part against python-control's nlsys simulation of it")
    b.add_argument("--steps", type=int, default=21000, metavar="N", help="steps per case (21000 = 1 s)")
    b.add_argument("--pairs", type=int, nargs="+", default=[5, 9, 17, 33], metavar="P",
                   help="contact pair counts")
    b.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    return b


def cmd_bench(cfg, args) -> int:
    from rt.loop.bench import bench_loop, bench_plant, format_loop, format_table
    if args.target == "loop":
        if args.steps < 1000:
            return fail(f"--steps {args.steps}: need at least 1000 steps")
        res = bench_loop(cfg, n_steps=args.steps)
        print(json.dumps(res) if args.json else format_loop(res))
        return 0
    if args.steps < 100:
        return fail(f"--steps {args.steps}: need at least 100 steps for percentiles")
    if any(p < 2 for p in args.pairs):
        return fail(f"--pairs {args.pairs}: every pair count must be >= 2")
    if not cfg.plant.interface.enabled:
        return fail("bench plant: times the contact step at several pair counts; this structure has no interface "
                    "(plant.interface.enabled = false)")
    res = bench_plant(cfg, args.pairs, args.steps, progress=not args.json)
    print(json.dumps(res) if args.json else format_table(res))
    return 0

