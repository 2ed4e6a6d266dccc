"""The step-sine channel's driving-point estimate (rt.discrepancy.diagnose.stepsine.prepare): which
lines it uses and how it weights them. The model's step-sines are replaced by fixed responses here
(``run_branches``), so the arithmetic is checked exactly; the figures measured on campaigns of
another model form are in the module docstring and docs/discrepancy.md."""
from types import SimpleNamespace

import numpy as np
import pytest

import frictionrt.rt.discrepancy.diagnose.stepsine as ds
from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.log.frf_files import FRFTest

FREQ = np.array([120.0, 212.0, 500.0])
H_FRF = np.array([2.0 + 1.0j, -3.0 + 0.5j, 1.5 - 2.0j])       # the model's accelerance at a_frf [(m/s^2)/N]
H_TIP = np.array([4.0 - 1.0j, 2.0 + 2.0j, -1.0 + 0.5j])       # ... and at the tip
R_EXC = np.array([1e-6 + 2e-7j, -4e-6 + 1e-6j, 3e-8 - 1e-8j])  # its driving-point receptance [m/N]
RHO = np.array([0.9, 1.07, 1.25])                              # measured F_amp / drive


def _response(R_exc):
    return SimpleNamespace(R_exc=R_exc, H_sensors={"a_frf_meas": H_FRF, "a_tip_meas": H_TIP})


@pytest.fixture
def prepared(monkeypatch):
    """prepare() on one test whose a_frf matches the model at every line and whose tip/a_frf ratio
    is the model's x 1.5 at 212 Hz; the model with k_n x 2 moves R_exc by x 3 at 500 Hz (an
    antiresonance of the driving point), with k_n / 2 by x 1.02 at every line."""
    cfg = with_sets(Config(), [])
    tip = H_TIP * np.array([1.0, 1.5, 1.0])
    test = FRFTest("stepsine_01", FREQ, {"a_frf_meas": H_FRF, "a_tip_meas": tip}, RHO * 5.0, np.full(3, 5.0),
                   {"kind": "stepsine", "F_N1_N": 300.0, "amplitude_n": 5.0})
    calls = []

    def fake_run_branches(branches, *args, **kwargs):
        calls.append(branches)
        k_n = [b.cfg.plant.interface.k_n_area / cfg.plant.interface.k_n_area for b in branches]
        return [_response(R_EXC * (np.array([1.0, 1.0, 3.0]) if f > 1.5 else np.full(3, 1.02 if f < 0.7 else 1.0)))
                for f in k_n]

    monkeypatch.setattr(ds, "run_branches", fake_run_branches)
    return ds.prepare(cfg, [test]), calls


def test_a_line_where_the_model_has_another_shape_is_not_used(prepared):
    data, _ = prepared
    np.testing.assert_array_equal(data.freq[0], [120.0, 500.0])
    np.testing.assert_allclose(data.R[0], (H_FRF * R_EXC / H_FRF)[[0, 2]])


def test_a_line_whose_estimate_moves_with_k_n_weighs_less(prepared):
    data, calls = prepared
    spread = np.array([np.log(1.02), np.log(3.0)])          # 120 Hz: under the floor; 500 Hz: above it
    expected = np.sqrt(ds.SIGMA ** 2 + (np.maximum(ds.DELTA_R_FLOOR, spread) * np.abs(1.0 - RHO[[0, 2]])) ** 2)
    np.testing.assert_allclose(data.sigma[0], expected, rtol=1e-12)
    assert data.sigma[0][1] > 5.0 * ds.SIGMA
    assert len(calls) == 1 and len(calls[0]) == 3   # one call: the model and its two k_n variants
