"""Pacing to the wall clock, shared by the loop (rt/loop/tick.py) and the replay (rt/loop/replay.py).

Absolute deadlines on CLOCK_MONOTONIC in ``clk[CLK_DEADLINE]`` [ns] (rt/common/clock.py): a paced
tick waits for its deadline (``_wait_for_deadline``), runs, and moves the deadline one period
on (``_next_deadline``). A tick that ends after the next deadline is an overrun: the deadline
skips ahead by whole periods and the missed periods are counted in ``clk[CLK_OVERRUNS]``, so a
late loop never runs ticks back to back to catch up, and the deadline never drifts.
"""
from __future__ import annotations

import numba

from rt.common.clock import CLK_DEADLINE, CLK_OVERRUNS, _now_ns


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _wait_for_deadline(clk, ts):
    """Busy-wait until ``clk[CLK_DEADLINE]`` [ns]; ts is the clock's (2,) int64 scratch. RT-safe."""
    while _now_ns(ts) < clk[CLK_DEADLINE]:
        pass


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _next_deadline(clk, period_ns, t_end):
    """The deadline after a tick that ended at t_end [ns]: one period_ns [ns] on, or on an overrun
    (t_end past it) skipped ahead by whole periods, which are counted in ``clk[CLK_OVERRUNS]``.
    Returns True on an overrun. RT-safe."""
    clk[CLK_DEADLINE] += period_ns
    if t_end > clk[CLK_DEADLINE]:
        missed = (t_end - clk[CLK_DEADLINE]) // period_ns + 1
        clk[CLK_OVERRUNS] += missed
        clk[CLK_DEADLINE] += missed * period_ns
        return True
    return False
