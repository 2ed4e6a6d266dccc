"""``frictionrt bench``: step-time benchmarks [us] of the compiled kernels (rt.loop.bench), and of the whole
controller in numba and as the C export (``bench controller --c DIR``, rt.export.bench)."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import shtab

from frictionrt.rt.cli.common import add_estimator, fail


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``bench`` (parents: frictionrt's --config/--set parser)."""
    b = sub.add_parser("bench", parents=parents, help="step-time benchmarks [us]",
                       description="Per-step wall time [us] of the compiled kernels: median, p99, p99.9, max.")
    b.add_argument("target", choices=["plant", "loop", "controller"],
                   help="plant: the Newmark/Newton step for 5, 9, 17, 33 pairs; loop: the whole tick and its controller "
                        "part against python-control's nlsys; controller: the whole controller, numba and C (--c DIR)")
    b.add_argument("--steps", type=int, default=21000, metavar="N", help="steps per case (21000 = 1 s)")
    b.add_argument("--pairs", type=int, nargs="+", default=[5, 9, 17, 33], metavar="P",
                   help="contact point counts, each at a uniform pitch over the interface (the default's graded "
                        "layout is 23 points: `frictionrt bench loop` times it)")
    b.add_argument("--c", metavar="DIR", default=None, help="controller: time the C export in DIR beside numba "
                   "(an export of the same configuration, law and estimator)").complete = shtab.DIRECTORY
    b.add_argument("--cc", metavar="CC", default=None, help="controller with --c: the C compiler (default: $CC or cc)")
    b.add_argument("--law", choices=["passive", "hysteresis", "lyapunov"], default="lyapunov",
                   help="controller: the law")
    add_estimator(b)
    b.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    return b


def cmd_bench(cfg, args) -> int:
    from frictionrt.rt.loop.bench import bench_loop, bench_plant, format_loop, format_table
    if args.target == "controller":
        return cmd_bench_controller(cfg, args)
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


def cmd_bench_controller(cfg, args) -> int:
    """``bench controller``: per-tick figures [us] of numba and the C export (rt/export/bench.py)."""
    from frictionrt.rt.export.bench import bench_controller, format_bench
    from frictionrt.rt.export.generate import read_manifest, require_double
    from frictionrt.rt.loop import build_loop, initial_loop_state
    if args.steps < 1000:
        return fail(f"--steps {args.steps}: need at least 1000 steps")
    try:
        manifest = read_manifest(Path(args.c)) if args.c else None
        if manifest is not None:
            require_double(manifest, f"--c {args.c}")
        loop = build_loop(cfg, args.law, args.estimator)
        res = bench_controller(loop, initial_loop_state(loop, cfg.rt.seed), args.steps, args.c, args.cc, manifest)
    except ValueError as exc:
        return fail(str(exc))
    print(json.dumps(res) if args.json else format_bench(res))
    return 0
