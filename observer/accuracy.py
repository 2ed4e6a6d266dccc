"""Estimation accuracy against the plant's truth (offline, on a run's log).

The plant's u_rel, v_rel carry, besides the structural motion, the near-Nyquist ringing of modes
the 21 kHz step does not resolve (docs/plant.md 2.6), which no estimator can or should follow.
The truth is therefore the plant's signal low-passed without phase (4th-order Butterworth,
forward-backward, at ``observer.oracle_bandwidth_hz``, the band the oracle passes):

    NRMSE(x) = rms(x_hat - x_true) / rms(x_true)   over the last `tail` share of the run.
"""
from __future__ import annotations

import numpy as np
import scipy.signal as ss

TAIL = 0.2  # the last 20 % of a run: the steady state, as for acc045_amplitude


def band_limited_truth(x: np.ndarray, dt: float, f_c: float) -> np.ndarray:
    """x low-passed without phase (4th-order Butterworth at f_c [Hz], forward-backward)."""
    return ss.sosfiltfilt(ss.butter(4, f_c, fs=1.0 / dt, output="sos"), x)


def nrmse(x_hat: np.ndarray, x_true: np.ndarray, tail: float = TAIL) -> float:
    """rms(x_hat - x_true) / rms(x_true) over the last `tail` share of the samples."""
    n = len(x_true)
    s = slice(n - max(int(tail * n), 2), n)
    return float(np.sqrt(np.mean((x_hat[s] - x_true[s]) ** 2) / np.mean(x_true[s] ** 2)))
