"""A monotonic nanosecond clock callable from njit code (libc ``clock_gettime``).

Used to time individual steps inside compiled loops, where Python's ``time`` is not reachable
and timing from Python would measure the call overhead instead of the step.
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

