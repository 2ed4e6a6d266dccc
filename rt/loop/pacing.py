"""Pacing to the wall clock, shared by the loop (rt/loop/tick.py), the replay (rt/loop/replay.py)
and the null loop (``_null_ticks``, the machine's floor).

Absolute deadlines on CLOCK_MONOTONIC in ``clk[CLK_DEADLINE]`` [ns] (rt/common/clock.py): a paced
tick waits for its deadline (``_wait_for_deadline``), runs, and moves the deadline one period
on (``_next_deadline``). A tick that ends after the next deadline is an overrun: the deadline
skips ahead by whole periods and the missed periods are counted in ``clk[CLK_OVERRUNS]``, so a
late loop never runs ticks back to back to catch up, and the deadline never drifts.

The wait sleeps and then spins: ``clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME)`` until
``margin_ns`` before the deadline, then a busy-wait on the clock to the deadline itself. The
sleep hands the core back for most of the period, so that a loop thread at SCHED_FIFO priority
never reaches the kernel's real-time throttle (``sched_rt_runtime_us``: 950 ms of each second),
which a loop spinning for the whole period hits; the spin absorbs the wake-up latency. A margin
of one period or more is a pure spin (the wait of a loop without real-time priority, where a
sleep's wake-up waits behind other threads).
"""
from __future__ import annotations

import numba
from numba import types

from frictionrt.rt.common.clock import CLK_DEADLINE, CLK_OVERRUNS, CLOCK_MONOTONIC, _now_ns

TIMER_ABSTIME = 1
START_SLACK_NS = 1_000_000  # a paced run's first deadline: 1 ms after its thread is ready (the first call's dispatch is no lateness)
# int clock_nanosleep(clockid_t, int flags, const struct timespec *request, struct timespec *remain)
_clock_nanosleep = types.ExternalFunction("clock_nanosleep", types.int32(types.int32, types.int32, types.voidptr,
                                                                          types.voidptr))


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _wait_for_deadline(clk, ts, margin_ns):
    """Sleep until margin_ns [ns] before ``clk[CLK_DEADLINE]`` [ns], then busy-wait to it; ts is
    the clock's (2,) int64 scratch (also the sleep's timespec). RT-safe."""
    deadline = clk[CLK_DEADLINE]
    wake = deadline - margin_ns
    if _now_ns(ts) < wake:
        ts[0] = wake // 1_000_000_000
        ts[1] = wake % 1_000_000_000
        _clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, ts.ctypes.data, ts.ctypes.data)
    while _now_ns(ts) < deadline:
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


@numba.njit(cache=True, nogil=True, _nrt=False)
def _null_ticks(period_ns, margin_ns, clk, ts, late):
    """The paced loop with an empty tick: len(late) ticks, each waiting for its deadline as the
    loop does; late[i] receives tick i's lateness [ns] (its start after the deadline). Overruns
    (a tick starting a whole period late) counted in clk[CLK_OVERRUNS] as in the loop. RT-safe."""
    for i in range(late.shape[0]):
        _wait_for_deadline(clk, ts, margin_ns)
        t = _now_ns(ts)
        late[i] = t - clk[CLK_DEADLINE]
        _next_deadline(clk, period_ns, _now_ns(ts))
