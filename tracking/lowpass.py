"""A 2nd-order Butterworth low-pass as one biquad per channel (direct form II transposed).

Used where a sampled signal must be band-limited inside the loop: the oracle estimator
(observer.oracle) and the force setpoint prefilter (tracking.prefilter). Designed with
scipy.signal.butter (bilinear transform with prewarping) at design time.

State: two values per channel (s1, s2), channel j at [2j, 2j+1]. Inputs u and outputs y:
one value per channel.
"""
from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
import scipy.signal as ss


class BiquadParams(NamedTuple):
    """b0 + b1 z^-1 + b2 z^-2 over 1 + a1 z^-1 + a2 z^-2 (scipy's sos row)."""
    b0: float
    b1: float
    b2: float
    a1: float
    a2: float


def build_butter2(fc_hz: float, dt: float, key: str) -> BiquadParams:
    """2nd-order Butterworth low-pass at fc_hz [Hz] for the step dt [s]; `key` names the
    configuration value in the error for a corner at or above Nyquist."""
    fs = 1.0 / dt
    if not (0.0 < fc_hz < 0.5 * fs):
        raise ValueError(f"{key} = {fc_hz:g} Hz must lie in (0, {0.5 * fs:g}) Hz (below the Nyquist frequency)")
    sos = ss.butter(2, fc_hz, fs=fs, output="sos")[0]
    return BiquadParams(*(float(v) for v in (sos[0], sos[1], sos[2], sos[4], sos[5])))


def rest_state(p: BiquadParams, values) -> np.ndarray:
    """State at rest with constant inputs `values` (one per channel; DC gain 1)."""
    x = np.zeros(2 * len(values))
    for j, v in enumerate(values):
        x[2 * j + 1] = (p.b2 - p.a2) * v
        x[2 * j] = (p.b1 - p.a1) * v + x[2 * j + 1]
    return x


@numba.njit(cache=True, nogil=True, _nrt=False)
def _biquad_step(k, x, u, p, x_next, y):
    """y = b0 u + s1;  s1' = b1 u - a1 y + s2;  s2' = b2 u - a2 y   per channel. RT-safe.

    Parameters: k int64 tick (unused: time-invariant); x (2 n,) state at t_k; u (n,) inputs;
    x_next (2 n,) written; y (n,) outputs at t_k, same units as u.
    """
    b0, b1, b2, a1, a2 = p.b0, p.b1, p.b2, p.a1, p.a2
    for j in range(u.shape[0]):
        v = u[j]
        out = b0 * v + x[2 * j]
        x_next[2 * j] = b1 * v - a1 * out + x[2 * j + 1]
        x_next[2 * j + 1] = b2 * v - a2 * out
        y[j] = out
