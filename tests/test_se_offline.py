"""The offline active-set solve of an imported structure (plant.se_offline) against the plant
kernel (plant.se_plant._se_step) on the small 3-D reference: the same trajectory to the Newton
tolerance through a hammer pulse that closes and opens points. Skipped without the [fe] extra."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("skfem")

from frictionrt.plant import fe3d  # noqa: E402
from frictionrt.plant.impulse import hammer_force  # noqa: E402
from frictionrt.plant.se_offline import ActiveSetStepper, run_active_set  # noqa: E402
from frictionrt.plant.se_plant import _run, build_se_plant  # noqa: E402
from frictionrt.rt.common.config import Config  # noqa: E402

COARSE = {"interface_pitch_m": 0.04, "pitch_m": 0.05, "cutoff_hz": 4000.0}
STEPS = 120        # the 0.5 ms pulse (11 steps) and 5 ms after it
F_N1 = 100.0


@pytest.fixture(scope="module")
def runs():
    cfg = Config()
    se, _ = fe3d.reference_superelement(cfg, **COARSE)
    plant = build_se_plant(se, cfg)
    imp = cfg.impulse
    force = hammer_force(int(round(imp.record_s / cfg.dt_s)), cfg.dt_s, imp.peak_N, imp.duration_s)[:STEPS]
    U = np.column_stack([force, np.full(STEPS, F_N1)])
    x0 = plant.initial_state(F_N1)
    Yk = np.zeros((STEPS, len(plant.output_labels())))
    xk, failed_k = _run(x0, U, plant.params, plant.new_work(), Yk)
    st = ActiveSetStepper(plant)
    x = x0.copy()
    Ya = np.zeros_like(Yk)
    failed_a = sum(st.step(x, U[k], Ya[k]) < 0 for k in range(STEPS))
    return cfg, plant, x0, U, (Yk, xk, failed_k), (Ya, x, failed_a), st


def test_active_set_solve_follows_the_kernel_to_the_newton_tolerance(runs):
    cfg, plant, x0, U, (Yk, xk, fk), (Ya, xa, fa), st = runs
    assert fk == 0 and fa == 0
    d = 1 + plant.params.nt
    g0 = x0[plant.state_slots()["g"]][0::d]
    assert 0 < (g0 < 0).sum() < plant.n_points        # some points open: the open block is exercised
    assert st.gathers >= 2                             # the pulse changed the active set
    tol = cfg.plant.newton_tol_m
    sl = plant.state_slots()
    # per substep both solve |r|_2 <= tol (plus round-off); over 120 steps the differences stay
    # within 100 tol in the gaps (measured 4e-18 m on gaps of 2.8e-6 m)
    assert np.abs(xa[sl["g"]] - xk[sl["g"]]).max() < 100 * tol
    ix = plant.output_index()
    names = plant.se.sensor_names
    # the sensors against the largest motion of any sensor (some directions barely move)
    cw, ca = [ix[f"w_{s}"] for s in names], [ix[f"a_{s}"] for s in names]
    motion = np.abs(Yk[:, cw] - Yk[0, cw]).max()
    assert np.abs(Ya[:, cw] - Yk[:, cw]).max() < 1e-9 * motion       # measured 2e-13 of the motion
    assert np.abs(Ya[:, ca] - Yk[:, ca]).max() < 1e-6 * np.abs(Yk[:, ca]).max()
    for e in ("E_fric", "W_exc", "F_N1"):
        assert Ya[-1, ix[e]] == pytest.approx(Yk[-1, ix[e]], rel=1e-9, abs=1e-15)


def test_run_active_set_wrapper_matches_the_stepper(runs):
    cfg, plant, x0, U, _, (Ya, xa, _), _ = runs
    Y, x, failed = run_active_set(plant, U[:30], x0)
    assert failed == 0
    np.testing.assert_array_equal(Y, Ya[:30])
