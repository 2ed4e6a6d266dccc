"""Semi-active control laws (SPEC section 4): the normal-force setpoint F* of the adaptive screw.

All three laws saturate to [F_min, F_max] (``cfg.tracking.F_min_N``, ``F_max_N``):

    passive       F* = sat(F_passive)
    hysteresis    F* = sat(K_f u0),  u0 from the RT1 amplitude filter      (Eq. 3, Eq. 4)
    lyapunov      F* = sat(F_max)                        if |v_rel| >= eps
                  F* = sat(max(F_max |v_rel| / eps, F_min))  otherwise     (SPEC 4, boundary layer)

    sat(F) = min(max(F, F_min), F_max)

One kernel for all three: the law is an integer code in the parameters (``LAW_CODES``), so the
loop compiles one call and never branches in Python. The RT1 state is advanced whatever the
law (its u0 is logged), by the RT1 step itself (``frictionrt.tracking.rt1._rt1_step``).

State slots ``LAWS_SLOTS`` = ``RT1_SLOTS`` = (u0 [m],). Inputs u = (u_rel [m], v_rel [m/s]).
Outputs y = (F_set [N], u0 [m]); u0 is the RT1 value at t_{k+1}, i.e. after u_rel,k
(``frictionrt.tracking.rt1``).
"""
from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from frictionrt.rt.common.config import LAWS, Config
from frictionrt.tracking.rt1 import RT1_SLOTS, RT1Params, _rt1_step, build_rt1

LAW_CODES = {name: i for i, name in enumerate(LAWS)}  # passive 0, hysteresis 1, lyapunov 2
PASSIVE, HYSTERESIS, LYAPUNOV = LAW_CODES["passive"], LAW_CODES["hysteresis"], LAW_CODES["lyapunov"]
LAWS_SLOTS = RT1_SLOTS
LAWS_INPUTS = (("u_rel", "m"), ("v_rel", "m/s"))
LAWS_OUTPUTS = (("F_set", "N"), ("u0", "m"))


class LawParams(NamedTuple):
    """Constants of the law step (built by ``build_laws``)."""
    law: int           # LAW_CODES[cfg.tracking.law] (int64 in the kernel)
    F_min: float       # [N]
    F_max: float       # [N]
    F_passive: float   # [N]
    K_f: float         # [N/m]
    eps: float         # boundary layer [m/s]
    rt1: RT1Params
    hold_voltage: bool  # passive law with tracking.passive_mode "voltage": the stack held at V_ff(F*)


def build_laws(cfg: Config, law: str | None = None) -> LawParams:
    """Law constants from ``cfg.tracking`` (``law`` overrides ``cfg.tracking.law``)."""
    t = cfg.tracking
    name = t.law if law is None else law
    if name not in LAW_CODES:
        raise ValueError(f"law = {name!r}: must be one of {', '.join(LAWS)} (tracking.law)")
    return LawParams(law=LAW_CODES[name], F_min=float(t.F_min_N), F_max=float(t.F_max_N),
                     F_passive=float(t.F_passive_N), K_f=float(t.K_f), eps=float(t.eps_m_s),
                     rt1=build_rt1(cfg), hold_voltage=bool(name == "passive" and t.passive_mode == "voltage"))


@numba.njit(cache=True, nogil=True, _nrt=False)
def _laws_step(k, x, u, p, x_next, y):
    """Normal-force setpoint of the configured law and one RT1 step. RT-safe.

        passive     F* = sat(F_passive)
        hysteresis  F* = sat(K_f u0_{k+1})                                   (Eq. 3)
        lyapunov    F* = sat(F_max) if |v_rel| >= eps else sat(max(F_max |v_rel|/eps, F_min))
        u0_{k+1} = a u0_k + (1 - a)(pi/2)|u_rel,k|                           (Eq. 4, ZOH)
        sat(F) = min(max(F, F_min), F_max)

    Parameters
    ----------
    k : int64 tick
    x : (1,) state at t_k, ``LAWS_SLOTS`` = (u0 [m],) (read only)
    u : (2,) inputs (u_rel [m], v_rel [m/s])
    p : LawParams (p.law: 0 passive, 1 hysteresis, 2 lyapunov)
    x_next : (1,) state at t_{k+1} (written)
    y : (2,) outputs (F_set [N], u0 [m]) (written)
    """
    law, F_min, F_max, eps = p.law, p.F_min, p.F_max, p.eps
    _rt1_step(k, x, u, p.rt1, x_next, y[1:])  # y[1] = u0 at t_{k+1}
    if law == HYSTERESIS:
        f = p.K_f * y[1]
    elif law == LYAPUNOV:
        av = abs(u[1])
        if av >= eps:
            f = F_max
        else:
            f = max(F_max * av / eps, F_min)
    else:
        f = p.F_passive
    y[0] = min(max(f, F_min), F_max)


def laws_step(k: int, x: np.ndarray, u: np.ndarray, p: LawParams, x_next: np.ndarray,
              y: np.ndarray) -> None:
    """Checked wrapper of ``_laws_step`` (use the kernel directly in loops)."""
    if x.shape != (len(LAWS_SLOTS),) or x_next.shape != x.shape:
        raise ValueError(f"state must have shape ({len(LAWS_SLOTS)},) = {LAWS_SLOTS}, "
                         f"got {x.shape}, {x_next.shape}")
    if u.shape != (2,) or y.shape != (2,):
        raise ValueError(f"u must be (u_rel [m], v_rel [m/s]) and y (F_set [N], u0 [m]); "
                         f"got shapes {u.shape}, {y.shape}")
    _laws_step(np.int64(k), x, u, p, x_next, y)
