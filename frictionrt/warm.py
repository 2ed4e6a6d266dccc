"""Compile the run-time kernels ahead of their first use: ``python -m frictionrt.warm [--jobs N]``.

Numba compiles each ``njit(cache=True)`` kernel on its first call and keeps the machine code in
its on-disk cache (rt.common.jit_cache: one folder per version of the kernel sources). On a cold
cache the first command pays for it (the plant's run ~55 s of CPU, the closed loop's tick ~45 s
more, profiled), and processes that start together each compile the same kernel in full:
numba has no lock between processes, so two test workers, or ``reproduce``'s and ``diagnose``'s
process pools, pay it once each. This module compiles the kernels of the main paths once, spread
over ``jobs`` processes in two rounds (round 2's entry points call kernels round 1 compiled, which
they then load from the cache), by running each path on a few ticks of the default configuration.
Nothing is written outside the cache; a warm cache makes it a few seconds.
"""
from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context


def _plant() -> None:
    """The plant's offline run (plant.simulate: ``impulse``) and an impulse test through the actuator
    and the sensors (the rig's and the diagnosis's measurement chain)."""
    import numpy as np

    from frictionrt.jobs import impulse
    from frictionrt.plant.model import build_plant
    from frictionrt.rt.common.config import load
    from frictionrt.rt.discrepancy.chain import measure_impulse
    impulse(fn1_n=100.0)
    measure_impulse(build_plant(load()), np.zeros(8), 0.0, 0)


def _harmonic() -> None:
    """The joints' harmonic balance by describing functions and by AFT (``diagnose --calibrate-on``)."""
    import numpy as np

    from frictionrt.plant.harmonic_frf import harmonic_accelerances, harmonic_system
    from frictionrt.plant.model import build_plant
    from frictionrt.rt.common.config import load
    cfg = load()
    hs = harmonic_system(build_plant(cfg), {"a": cfg.plant.frf_point}, 100.0)
    for method in ("df", "aft"):
        harmonic_accelerances(hs, 1.0, np.array([230.0]), method=method)


def _stuck_matching() -> None:
    """The stuck system's period matching (``plant.period_match_stuck``): the design steps the plant
    kernel from Python about the static state, on arrays of another type than the runs' (writable),
    so it compiles its own ~45 s the first time."""
    from frictionrt.plant.model import build_plant
    from frictionrt.rt.common.config import load
    build_plant(load(None, ["plant.period_match_stuck=true"]))


def _loop_and_replays() -> None:
    """The closed loop (``simulate``) with its log, and the log's replay through the controller."""
    import tempfile
    from pathlib import Path

    from frictionrt.jobs import replay, simulate
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "warm"
        simulate(freq_hz=230.0, amp_n=5.0, law="hysteresis", duration_s=0.01, out=out, rrd=False)
        replay(out.with_suffix(".mcap"))


def _replay_plant() -> None:
    """A log's replay through the actuator and the plant (``replay --plant``)."""
    import tempfile
    from pathlib import Path

    from frictionrt.jobs import replay, simulate
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "warm"
        simulate(freq_hz=230.0, amp_n=5.0, law="lyapunov", duration_s=0.01, out=out, rrd=False)
        replay(out.with_suffix(".mcap"), plant=True)


def _stepsine() -> None:
    """A step-sine point as ``reproduce``'s workers run it, on the observer and on the oracle: the loop
    pickled and unpickled on its way to the worker comes back with writable arrays, another type
    than the design's read-only ones, so the tick compiles once more for it."""
    import pickle

    import cloudpickle

    from frictionrt.rt.common.config import load
    from frictionrt.rt.experiments.branches import Branch, run_branch
    from frictionrt.rt.experiments.stepsine import Settle
    from frictionrt.rt.loop import build_loop
    cfg = load()
    settle = Settle(periods_per_block=1, min_block_s=0.005, n_blocks=2, rel_tol=0.5, max_s=0.03)
    for estimator in ("observer", "oracle"):
        loop = pickle.loads(cloudpickle.dumps(build_loop(cfg, "hysteresis", estimator)))
        run_branch(Branch(cfg, "hysteresis", 5.0, (200.0,), estimator, settle), loop)


ROUNDS = ((_plant, _harmonic, _stuck_matching, _stepsine), (_loop_and_replays, _replay_plant))
"""The paths, in rounds: round 1 compiles the plant step that round 2's entry points call; in a
round the jobs start in this order on the free process (round 1 on two: the plant's, then the
step-sine's; the harmonic balance's, then the stuck matching's)."""


def _timed(job) -> tuple[str, float, str | None]:
    """(path name, wall time [s], None or the one-line error that stopped it)."""
    t = time.perf_counter()
    try:
        job()
    except Exception as exc:   # reported, not raised: the other paths still compile
        return job.__name__.lstrip("_"), time.perf_counter() - t, f"{type(exc).__name__}: {exc}".splitlines()[0]
    return job.__name__.lstrip("_"), time.perf_counter() - t, None


def warm(jobs: int = 2, say=print) -> tuple[float, list[str]]:
    """Run ``ROUNDS`` on ``jobs`` processes (1: in this process); ``say(text)`` after each path with
    its wall time. Returns (the total wall time [s], one line per path that failed)."""
    t0, failed = time.perf_counter(), []
    for jobs_of_round in ROUNDS:
        if jobs <= 1:
            done = [_timed(j) for j in jobs_of_round]
        else:
            with ProcessPoolExecutor(min(jobs, len(jobs_of_round)), mp_context=get_context("spawn")) as pool:
                done = list(pool.map(_timed, jobs_of_round))
        for name, s, err in done:
            say(f"  {name}: {s:.1f} s" + (f", failed: {err}" if err else ""))
            if err:
                failed.append(f"{name}: {err}")
    return time.perf_counter() - t0, failed


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m frictionrt.warm", description=__doc__.split("\n\n")[0])
    p.add_argument("--jobs", type=int, default=2, metavar="N", help="processes (default: 2; 1: this process)")
    args = p.parse_args(argv)
    if args.jobs < 1:
        print(f"warm: --jobs {args.jobs}: give 1 or more processes", file=sys.stderr)
        return 2
    print("compiling the run-time kernels (once per version of their sources)", file=sys.stderr)
    total, failed = warm(args.jobs, lambda s: print(s, file=sys.stderr))
    print(f"warm: {total:.1f} s wall" + (f"; {len(failed)} path(s) failed (their kernels compile on first use)"
                                         if failed else ""), file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
