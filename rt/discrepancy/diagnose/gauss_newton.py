"""Bounded Gauss-Newton with Broyden's rank-one Jacobian updates: the stage-2 optimiser of the
structure fit (rt.discrepancy.diagnose.structure) and of the FRF-file fit (rt.discrepancy.diagnose.frf).
A model evaluation there costs 0.1-0.4 s (the rig's chain on every test), so the Jacobian is
recomputed by forward differences only when a step fails."""
from __future__ import annotations

import numpy as np
from scipy.optimize import lsq_linear

MAX_STEPS = 10                          # stage-2 steps at most
CONVERGED = 1e-3                        # stage 2 stops when the cost drops by less (relative)


def jacobian_column(evaluate, x: np.ndarray, r: np.ndarray, j: int, steps: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """d(model)/d(theta_j) by a forward difference of ``steps[j]`` (backward at the upper bound);
    ``evaluate(x) -> (run, r)`` with r = measurement - model."""
    xj = x.copy()
    h = steps[j] if x[j] + steps[j] <= hi[j] else -steps[j]
    xj[j] += h
    return -(evaluate(xj)[1] - r) / h


def gauss_newton_broyden(evaluate, x, run, r, J, lo, hi, steps, max_steps: int = MAX_STEPS, box=None):
    """Bounded Gauss-Newton steps (scipy.optimize.lsq_linear) from x (``run``, residuals r, the
    Jacobian J or None: computed) with Broyden's rank-one update of J after each step (in units of
    ``steps``), recomputed by finite differences only when a step fails; a fresh Jacobian's step is
    halved up to twice. Stops when the cost drops by less than ``CONVERGED`` (relative), after
    ``max_steps`` (default MAX_STEPS) or when a fresh Jacobian's step fails. ``box(x) -> (lo, hi)``: the
    bounds of one step from x (within lo, hi; default lo, hi themselves). Returns (x, run, r, J)."""
    def column(x, r, j):
        return jacobian_column(evaluate, x, r, j, steps, hi)

    fresh = J is None
    if J is None:
        J = np.column_stack([column(x, r, j) for j in range(len(x))])
    for _ in range(max_steps):
        lo_x, hi_x = box(x) if box else (lo, hi)
        dx = lsq_linear(J, r, bounds=(lo_x - x, hi_x - x)).x
        cost = float(r @ r)
        for _ in range(3 if fresh else 1):             # a fresh Jacobian's step is halved up to twice
            run1, r1 = evaluate(x + dx)
            cost1 = float(r1 @ r1)
            if cost1 < cost:
                break
            dx = dx / 2
        if cost1 < cost:
            dz = dx / steps                                 # Broyden's update in step units
            J = J + np.outer(-(r1 - r) - J @ dx, dz / steps) / (dz @ dz)
            x, run, r = x + dx, run1, r1
            fresh = False
            if cost - cost1 < CONVERGED * cost:
                break
            continue
        if fresh:
            break
        J = np.column_stack([column(x, r, j) for j in range(len(x))])
        fresh = True
    return x, run, r, J
