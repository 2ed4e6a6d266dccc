"""Offline runs of the plant alone: a compiled loop over prescribed inputs.

Used by the impulse test, the checks and the benchmark; the closed loop (sensors, laws,
tracking) lives in ``rt/``.
"""
from __future__ import annotations

import numba
import numpy as np

from frictionrt.plant.model import PlantModel
from frictionrt.plant.newmark import _plant_step
from frictionrt.rt.common.clock import _now_ns


@numba.njit(cache=True, nogil=True)
def _run(x0, U, p, wk, Y, step_ns):
    """Step the plant over the rows of U (n_steps, 2) = (F_exc [N], F_N1 [N]) from state x0.

    Fills Y (n_steps, n_out) with the outputs after each step and step_ns (n_steps,) with
    the wall time of each step [ns]. Returns (final state, number of failed Newton solves).
    """
    x = x0.copy()
    x_next = np.empty_like(x0)
    ts = np.zeros(2, dtype=np.int64)
    failed = 0
    for k in range(U.shape[0]):
        t0 = _now_ns(ts)
        it = _plant_step(k, x, U[k], p, x_next, Y[k], wk)
        step_ns[k] = _now_ns(ts) - t0
        if it < 0:
            failed += 1
        x, x_next = x_next, x
    return x, failed


def run(model: PlantModel, F_exc: np.ndarray, F_N1: np.ndarray | float, x0: np.ndarray | None = None):
    """Simulate the plant for len(F_exc) controller steps.

    Parameters: F_exc [N] per step; F_N1 [N] per step or constant; x0 initial state
    (default: static equilibrium at the first F_N1).
    Returns (Y, x_final, step_ns) with Y (n_steps, n_out) labelled by ``model.output_labels()``.
    Raises RuntimeError if a contact Newton solve failed or a NaN appeared.
    """
    F_exc = np.asarray(F_exc, dtype=np.float64)
    U = np.empty((len(F_exc), 2))
    U[:, 0] = F_exc
    U[:, 1] = F_N1
    if x0 is None:
        x0 = model.initial_state(float(U[0, 1]))
    Y = np.empty((len(F_exc), len(model.output_labels())))
    step_ns = np.empty(len(F_exc), dtype=np.int64)
    x, failed = _run(x0, U, model.params, model.new_work(), Y, step_ns)
    if failed:
        undamped = (" or give the interface its dashpots (plant.interface.tau_s = 0 here; 1e-6 s or more: "
                    "docs/plant.md 2.6)" if model.cfg.plant.interface.tau_s == 0.0 else "")
        raise RuntimeError(f"the contact solve did not converge in {failed} of {len(U)} steps, even on "
                           f"{model.cfg.plant.fallback_split} fallback substeps; raise plant.substeps or "
                           f"plant.fallback_split (e.g. --set plant.substeps=2){undamped}")
    if not np.all(np.isfinite(Y)):
        raise RuntimeError("the plant produced NaN/Inf: check the configuration's stiffnesses and inputs")
    return Y, x, step_ns
