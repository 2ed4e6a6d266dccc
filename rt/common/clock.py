"""A monotonic nanosecond clock callable from njit code (libc ``clock_gettime``).

Used to time individual steps inside compiled loops, where Python's ``time`` is not reachable
and timing from Python would measure the call overhead instead of the step. Also the slots of
the loop's shared clock array ``clk`` (int64), which the compiled loop, the log writer and the
Python side watching a run read and write.
"""
from __future__ import annotations

import numba
from numba import types

CLOCK_MONOTONIC = 1
# resolved by name when the compiled code is linked (not a baked-in pointer), so callers cache
_clock_gettime = types.ExternalFunction("clock_gettime", types.int32(types.int32, types.voidptr))


@numba.njit(cache=True, nogil=True)
def _now_ns(ts):
    """Monotonic time [ns]; `ts` is a preallocated int64 array of length 2 (timespec). RT-safe."""
    _clock_gettime(CLOCK_MONOTONIC, ts.ctypes.data)
    return ts[0] * 1_000_000_000 + ts[1]



# state shared by the chunks of one run and the Python threads watching it (int64): next deadline
# [ns], overruns, ticks run, stop request (set by the watcher: the loop ends after its tick),
# written: ticks below this absolute tick are out of the ring (set by the writer; offline the loop
# waits for it before overwriting a row)
CLK_DEADLINE, CLK_OVERRUNS, CLK_TICKS, CLK_STOP, CLK_WRITTEN = 0, 1, 2, 3, 4
CLK_SIZE = 5
NO_WAIT = 2**62  # CLK_WRITTEN when no writer drains the log: the loop never waits
