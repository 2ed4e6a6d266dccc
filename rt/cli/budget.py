"""``frictionrt budget``: per-component tick times [us] against the 47.6 us budget (rt.loop.budget)."""
from __future__ import annotations

import argparse
import json

from frictionrt.rt.cli.common import add_estimator, add_realtime, fail, realtime_notes


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``budget`` (parents: frictionrt's --config/--set parser)."""
    g = sub.add_parser("budget", parents=parents, help="per-component tick times [us] against the 47.6 us budget",
                       description="Run the loop offline (timed per component) and paced; print median, p99, "
                                   "p99.9 and max [us] per component and for the whole tick, and the paced run's "
                                   "missed periods, lateness [us] and drift [us], next to what the machine allows "
                                   "at the same period, priority and core: the null loop (the same pacing, an "
                                   "empty tick) and, when installed, cyclictest (rt-tests). With --rt-priority N "
                                   "--cpu K the loop thread alone runs at SCHED_FIFO N on core K "
                                   "(docs/loop.md, 'Real-time set-up').")
    g.add_argument("--ticks", type=int, default=105000, metavar="N", help="offline ticks (21000 = 1 s)")
    g.add_argument("--paced-s", type=float, default=5.0, metavar="S", help="paced run length [s]")
    g.add_argument("--law", choices=["passive", "hysteresis", "lyapunov"], default="lyapunov", help="control law")
    add_estimator(g)
    add_realtime(g)
    g.add_argument("--no-floor", action="store_true", help="leave out the null loop and cyclictest")
    g.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    return g


def cmd_budget(cfg, args) -> int:
    from frictionrt.rt.loop.budget import budget, format_budget
    if args.ticks < 1000 or args.paced_s <= 0:
        return fail(f"--ticks {args.ticks} / --paced-s {args.paced_s}: need >= 1000 ticks and a positive paced time")
    try:
        res = budget(cfg, args.law, args.ticks, args.paced_s, floor=not args.no_floor, estimator=args.estimator)
    except ValueError as exc:
        return fail(str(exc))
    realtime_notes(res["paced"]["realtime"])
    print(json.dumps(res) if args.json else format_budget(res))
    return 0

