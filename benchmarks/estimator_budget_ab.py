"""The estimator's cost in the tick, the paper's observer against the amplitude-following one, A/B
alternating in one process (``frictionrt budget``'s offline timed run, its "estimator" component:
the clock read after the sanitising and the estimator step; docs/studies/observer-amplitude.md).

    python -m benchmarks.estimator_budget_ab [--rounds 6] [--ticks 42000] [--law lyapunov]
                                             [--estimators observer amplitude amplitude:0.1]

An estimator given as KIND:SCALE is designed with observer.spring_scale = SCALE.

Prints per round and kind the estimator's median and p99.9 [us] and the whole tick's median, then
per kind the median over rounds; the load average (os.getloadavg) before and after.
"""
import argparse
import os

import numpy as np

from frictionrt.rt.common.config import load, with_sets
from frictionrt.rt.loop import build_loop, run
from frictionrt.rt.loop.budget import EXC_AMP_N, EXC_FREQ_HZ
from frictionrt.rt.loop.build import COMPONENTS

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--ticks", type=int, default=42000)
    ap.add_argument("--law", default="lyapunov", choices=["hysteresis", "lyapunov"])
    ap.add_argument("--estimators", nargs="+", default=["observer", "amplitude"],
                    help="estimator kinds, each optionally KIND:SCALE (observer.spring_scale)")
    a = ap.parse_args()
    cfg = load()
    loops = {}
    for e in a.estimators:
        kind, _, scale = e.partition(":")
        c = with_sets(cfg, [f"observer.spring_scale={scale}"]) if scale else cfg
        loops[e] = build_loop(c, a.law, kind)
    col = COMPONENTS.index("estimator")
    for lp in loops.values():
        run(lp, EXC_FREQ_HZ, EXC_AMP_N, 0.01, timing=True)  # compile or load the cache
    print(f"load average before: {os.getloadavg()}")
    res = {e: [] for e in loops}
    for k in range(a.rounds):
        order = list(loops) if k % 2 == 0 else list(reversed(loops))
        for e in order:
            r = run(loops[e], EXC_FREQ_HZ, EXC_AMP_N, a.ticks * cfg.dt_s, timing=True)
            us = r.comp_ns[:, col] / 1e3
            tick = np.median(r.signal("tick_ns")) / 1e3
            res[e].append((np.median(us), np.percentile(us, 99.9), tick))
            print(f"round {k} {e:>10}: estimator median {res[e][-1][0]:.3f} us, p99.9 {res[e][-1][1]:.3f} us; "
                  f"tick median {tick:.2f} us", flush=True)
    print(f"load average after: {os.getloadavg()}")
    print("| estimator | estimator median [us] | estimator p99.9 [us] | tick median [us] | rounds |")
    print("| --- | --- | --- | --- | --- |")
    for e, rows in res.items():
        m = np.median(np.array(rows), axis=0)
        print(f"| {e} | {m[0]:.3f} | {m[1]:.3f} | {m[2]:.2f} | {len(rows)} |")
