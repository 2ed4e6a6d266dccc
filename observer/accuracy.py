"""Estimation accuracy against the plant's truth (offline, on a run's log).

The plant's u_rel, v_rel carry, besides the structural motion, the near-Nyquist ringing of modes
the 21 kHz step does not resolve (docs/plant.md 2.6), which no estimator can or should follow.
The truth is therefore the plant's signal low-passed without phase (4th-order Butterworth,
forward-backward, at ``observer.oracle_bandwidth_hz``, the band the oracle passes):

    NRMSE(x) = rms(x_hat - x_true) / rms(x_true)   over the last `tail` share of the run.

Every measure compares the estimate with the truth at the same instant. Row k of a run's log
holds the controller's outputs of tick k (the estimate at t_k, from the readings at t_k) but the
plant's outputs after its step over [t_k, t_k+1], at t_k+1 (``frictionrt.rt.loop.tick``, stage 7):
``at_estimate_instant`` pairs the estimate of row k + 1 with the truth of row k. Row by row, a
perfect estimate of a sine of frequency f would show NRMSE = 2 sin(pi f dt) (0.055 at 185 Hz,
0.11 at 370 Hz at 21 kHz): one tick of lag that is the log's layout, not the estimator's.

What the Lyapunov law uses is the size and sign of v_rel: ``sign_error_rate`` (|v_rel|-weighted) and
the error of its command F* (``lyapunov_command_error``).
"""
from __future__ import annotations

import numpy as np
import scipy.signal as ss

TAIL = 0.2  # the last 20 % of a run: the steady state, as for acc045_amplitude


def band_limited_truth(x: np.ndarray, dt: float, f_c: float) -> np.ndarray:
    """x low-passed without phase (4th-order Butterworth at f_c [Hz], forward-backward)."""
    return ss.sosfiltfilt(ss.butter(4, f_c, fs=1.0 / dt, output="sos"), x)


def at_estimate_instant(x_hat: np.ndarray, x_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x_hat[1:], x_rows[:-1]): the estimates of a run's log (row k at t_k) paired with the plant's
    logged truth at the same instants (row k at t_k+1; module docstring)."""
    return x_hat[1:], x_rows[:-1]


def nrmse(x_hat: np.ndarray, x_true: np.ndarray, tail: float = TAIL) -> float:
    """rms(x_hat - x_true) / rms(x_true) over the last `tail` share of the samples."""
    n = len(x_true)
    s = slice(n - max(int(tail * n), 2), n)
    return float(np.sqrt(np.mean((x_hat[s] - x_true[s]) ** 2) / np.mean(x_true[s] ** 2)))


def tail_slice(n: int, tail: float = TAIL) -> slice:
    """The last `tail` share of n samples (at least 2), as ``nrmse`` takes it."""
    return slice(n - max(int(tail * n), 2), n)


def sign_error_rate(v_hat: np.ndarray, v_true: np.ndarray, tail: float = TAIL) -> float:
    """Share of |v_true| carried by ticks whose estimate has the wrong sign, over the last `tail`:

        sum |v_true| [sign(v_hat) != sign(v_true)] / sum |v_true|     [-]

    0 for a perfect sign, 0.5 for an estimate that is independent of the truth's sign. Weighted
    by |v_true|, a wrong sign near a zero crossing (where any estimate is uncertain and the
    Lyapunov law commands little: F* ~ F_max |v| / eps) counts little."""
    s = tail_slice(len(v_true), tail)
    w = np.abs(v_true[s])
    wrong = np.sign(v_hat[s]) != np.sign(v_true[s])
    return float(np.sum(w[wrong]) / np.sum(w)) if np.sum(w) > 0 else float("nan")


def lyapunov_command(v: np.ndarray, F_min: float, F_max: float, eps: float) -> np.ndarray:
    """The Lyapunov law's normal-force command F* [N] for relative velocities v [m/s] (SPEC 4,
    ``frictionrt.tracking.laws._laws_step``, plain NumPy):

        F* = F_max                          if |v| >= eps
        F* = max(F_max |v| / eps, F_min)    otherwise,      then clipped to [F_min, F_max]"""
    av = np.abs(v)
    f = np.where(av >= eps, F_max, np.maximum(F_max * av / eps, F_min))
    return np.clip(f, F_min, F_max)


def lyapunov_command_error(v_hat: np.ndarray, v_true: np.ndarray, F_min: float, F_max: float, eps: float,
                           tail: float = TAIL) -> tuple[float, float]:
    """(rms, mean) of F*(v_hat) - F*(v_true) [N] over the last `tail` (``lyapunov_command``): the
    error of the Lyapunov law's command computed from the estimate against the one computed from
    the truth at the same instant."""
    s = tail_slice(len(v_true), tail)
    d = lyapunov_command(v_hat[s], F_min, F_max, eps) - lyapunov_command(v_true[s], F_min, F_max, eps)
    return float(np.sqrt(np.mean(d**2))), float(np.mean(d))
