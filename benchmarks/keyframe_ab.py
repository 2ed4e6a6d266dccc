"""What key frames cost the loop: the same run with none, with key frames, and with key frames
holding the contact solver's factor cache, alternating in one process.

    python -m benchmarks.keyframe_ab [--rounds 6] [--seconds 1] [--interval 2100] [--law lyapunov]

Each round runs the closed loop offline (``frictionrt.rt.loop.driver.run``, a writer that takes
nothing: the log holds the whole run, so no writer thread competes) once per variant, in turn:
``off`` (rt.keyframe_ticks = 0), ``on`` (the interval, rt.keyframe_plant_cache false) and
``cache`` (true). Printed per variant, the median over the rounds [min..max] of: the run's mean
tick_ns (the loop's own time per tick, the copy included: the amortised cost), its median, the
median tick_ns of the key-frame ticks (k mod interval = 0) and of the ticks after them; and the
key frame's size. Times on a shared machine: read them against each other, with the load.
"""
from __future__ import annotations

import argparse
import os
import statistics
from types import SimpleNamespace

import numpy as np

from benchmarks.entry import run_main


class _Sink:
    """A LogWriter stand-in: the key-frame channel of ``codec``, no ring (the log holds the run),
    nothing written."""

    def __init__(self, codec):
        self.ring_ticks = None
        self.error = None
        self.mcap = SimpleNamespace(keyframes=codec)

    def start(self, *args, **kwargs):
        pass

    def finish(self):
        pass


def loops(law: str, interval: int) -> dict:
    """The loop of each variant (one plant and force-tracking design for all)."""
    from frictionrt.rt.common.config import load
    from frictionrt.rt.loop import Designs, build_loop
    designs = Designs()
    sets = {"off": ["rt.keyframe_ticks=0"], "on": [f"rt.keyframe_ticks={interval}"],
            "cache": [f"rt.keyframe_ticks={interval}", "rt.keyframe_plant_cache=true"]}
    return {v: build_loop(load(None, s), law, "observer", designs=designs) for v, s in sets.items()}


def one_run(loop, seconds: float, interval: int) -> dict:
    """One offline run of ``loop``: its tick_ns figures [ns] and the key frame's size [doubles]."""
    from frictionrt.rt.loop import initial_loop_state, run
    from frictionrt.rt.loop.keyframe import keyframe_codec
    codec = keyframe_codec(loop, initial_loop_state(loop, loop.cfg.rt.seed))
    r = run(loop, 223.6, 20.0, seconds, writer=_Sink(codec) if codec is not None else None)
    ns = r.signal("tick_ns")
    k = np.arange(len(ns))
    key = k % interval == 0
    after = k % interval == 1
    return {"mean": float(ns.mean()), "median": float(np.median(ns)), "key": float(np.median(ns[key])),
            "after": float(np.median(ns[after])),
            "doubles": 0 if codec is None else sum(s for _, _, s in codec.parts)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--interval", type=int, default=2100)
    ap.add_argument("--law", default="lyapunov")
    args = ap.parse_args()
    lp = loops(args.law, args.interval)
    variants = tuple(lp)
    for v in variants:   # compile or load the kernels of each variant: not measured
        one_run(lp[v], 0.02, args.interval)
    got: dict[str, list[dict]] = {v: [] for v in variants}
    load0 = os.getloadavg()[0]
    for _ in range(args.rounds):
        for v in variants:
            got[v].append(one_run(lp[v], args.seconds, args.interval))
    print(f"keyframe_ab: {args.law}/observer, 223.6 Hz 20 N, {args.seconds:g} s x {args.rounds} rounds, interval "
          f"{args.interval}; load average {load0:.1f} -> {os.getloadavg()[0]:.1f}")
    print(f"{'variant':>8} {'doubles':>8} {'mean tick [us]':>22} {'median tick [us]':>22} "
          f"{'key-frame tick [us]':>22} {'next tick [us]':>22}")
    for v in variants:
        rows = got[v]

        def fmt(key):
            xs = [r[key] / 1e3 for r in rows]
            return f"{statistics.median(xs):.3f} [{min(xs):.3f}..{max(xs):.3f}]"
        print(f"{v:>8} {rows[0]['doubles']:>8} {fmt('mean'):>22} {fmt('median'):>22} {fmt('key'):>22} "
              f"{fmt('after'):>22}")
    return 0


if __name__ == "__main__":
    run_main(main)
