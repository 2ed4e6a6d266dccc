"""A structural candidate's joint start (rt.discrepancy.diagnose.structure.joint_start): the calibration's
point with the modal damping scale and the effect's strength chosen together on a grid, clipped to the
fit's bounds. The diagnosis on campaigns is tests/test_diagnose.py; the own-form campaigns this start
was made for are docs/discrepancy.md, "The refined whole form"."""
import math

import numpy as np

from frictionrt.rt.discrepancy.diagnose.structure import JOINT_DAMPING, JOINT_STRENGTH, joint_start


def quadratic(target: np.ndarray):
    """evaluate(z) -> (run, r) with r the distance to ``target`` in the optimiser's variables and the
    calls counted in run."""
    calls = []

    def evaluate(z):
        calls.append(z.copy())
        return len(calls), np.asarray(z - target, dtype=float)
    return evaluate, calls


def test_the_grid_point_nearest_a_valley_below_the_calibrations_damping():
    # z: ln E-like, ln damping, strength; calibration at damping 1.2 (ln), effect at 0; the valley at
    # damping x 0.84 (2^-1/4) and 0.75 x the default 0.4: the grid's point itself
    z_cal = np.array([0.0, math.log(1.2), 0.0])
    target = np.array([0.0, math.log(1.2 * 2 ** -0.25), 0.3])
    evaluate, calls = quadratic(target)
    lo, hi = np.array([-1.0, math.log(0.1), 0.0]), np.array([1.0, math.log(10.0), 0.95])
    z, run, r = joint_start(evaluate, z_cal, 1, 0.4, lo, hi)
    assert len(calls) == len(JOINT_DAMPING) * len(JOINT_STRENGTH) == 28
    np.testing.assert_allclose(z, target, atol=1e-12)
    assert r @ r < 1e-24 and np.array_equal(calls[run - 1], z)
    # the start it replaced (damping x 1, the default strength) is one of the grid's points
    assert any(np.allclose(c, [0.0, math.log(1.2), 0.4]) for c in calls)


def test_points_outside_the_bounds_are_clipped():
    z_cal = np.array([math.log(0.12), 0.0])        # damping 0.12 near its lower bound 0.1
    evaluate, calls = quadratic(np.array([math.log(0.01), 0.05]))
    lo, hi = np.array([math.log(0.1), 0.0]), np.array([math.log(10.0), 0.2])
    z, _, _ = joint_start(evaluate, z_cal, 0, 0.4, lo, hi)
    assert all(np.all(c >= lo) and np.all(c <= hi) for c in calls)
    np.testing.assert_allclose(z, [math.log(0.1), 0.1])   # the lowest damping, the strength 0.25 x 0.4
