"""RT1 amplitude filter (paper Eq. 4, SPEC section 4): the slip amplitude u0 of the relative
displacement u_rel for the hysteresis-optimal law.

    T1 du0/dt + u0 = (pi/2) |u_rel|                                              (Eq. 4)

pi/2 turns the mean of a rectified sine, (2/pi) A, into its amplitude A; T1 sets how fast u0
follows. Exact zero-order-hold discretisation over dt (|u_rel| held over [t_k, t_{k+1})):

    u0_{k+1} = a u0_k + (1 - a) (pi/2) |u_rel,k|,      a = exp(-dt / T1).

The unit DC gain of the recursion means that in periodic steady state the mean of u0 over whole
periods equals the mean of (pi/2)|u_rel,k| over the samples, A to O((pi/N)^2) for a sine of N
samples per period (docs/tracking.md, section 1).

State slots ``RT1_SLOTS``: u0 [m]. Input u = (u_rel [m],). Output y = (u0 at t_{k+1} [m],):
the filter value after taking in u_rel,k, so a law evaluated at tick k uses the newest sample.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from frictionrt.rt.common.config import Config

RT1_SLOTS = ("u0",)
HALF_PI = 0.5 * math.pi


class RT1Params(NamedTuple):
    """Constants of the RT1 step (built by ``build_rt1``)."""
    a: float   # exp(-dt / T1) [-]
    b: float   # (1 - a) pi / 2 [-]


def build_rt1(cfg: Config) -> RT1Params:
    """RT1 constants for dt = ``cfg.dt_s`` and T1 = ``cfg.tracking.T1_s`` (exact ZOH, Eq. 4)."""
    r = cfg.dt_s / cfg.tracking.T1_s
    # 1 - a by expm1: dt/T1 ~ 1e-3, a plain 1 - exp(-r) would lose ~3 digits
    return RT1Params(a=float(math.exp(-r)), b=float(-math.expm1(-r) * HALF_PI))


@numba.njit(cache=True, nogil=True, _nrt=False)
def _rt1_step(k, x, u, p, x_next, y):
    """One step of the RT1 amplitude filter, exact ZOH of Eq. 4. RT-safe.

        u0_{k+1} = a u0_k + (1 - a) (pi/2) |u_rel,k|,   a = exp(-dt/T1)

    Parameters
    ----------
    k : int64 tick (the filter is time-invariant; kept for the uniform step signature)
    x : (1,) state at t_k, ``RT1_SLOTS`` = (u0 [m],) (read only)
    u : (>=1,) inputs, u[0] = u_rel,k [m] (further entries are ignored)
    p : RT1Params
    x_next : (1,) state at t_{k+1} (written)
    y : (>=1,) y[0] = u0 at t_{k+1} [m] (written)
    """
    a, b = p.a, p.b
    u0 = a * x[0] + b * abs(u[0])
    x_next[0] = u0
    y[0] = u0


def rt1_step(k: int, x: np.ndarray, u: np.ndarray, p: RT1Params, x_next: np.ndarray,
             y: np.ndarray) -> None:
    """Checked wrapper of ``_rt1_step`` (use the kernel directly in loops)."""
    if x.shape != (len(RT1_SLOTS),) or x_next.shape != x.shape:
        raise ValueError(f"state must have shape ({len(RT1_SLOTS)},) = {RT1_SLOTS}, "
                         f"got {x.shape}, {x_next.shape}")
    if u.shape != (1,) or y.shape != (1,):
        raise ValueError(f"u must be (u_rel [m],) and y (u0 [m],); got shapes {u.shape}, {y.shape}")
    _rt1_step(np.int64(k), x, u, p, x_next, y)
