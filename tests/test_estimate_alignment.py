"""The estimation errors compare the estimate with the truth at the same instant
(observer/accuracy.py ``at_estimate_instant``): on a synthetic log whose rows hold the truth one tick
after the estimate, as a run's log does (rt/loop/tick.py stage 7), a perfect estimate scores 0."""
from types import SimpleNamespace

import numpy as np
import pytest

from frictionrt.rt.common.config import load


def _fake_run(v_hat, u_hat, v_rows, u_rows, u0):
    """What ``frictionrt.rt.loop.results._estimation_errors`` reads of a Run: the signals by name,
    the loop's configuration, law and estimator, the rows held and the ticks."""
    sig = {"v_rel_hat": v_hat, "u_rel_hat": u_hat, "v_rel": v_rows, "u_rel": u_rows, "u0": u0}
    loop = SimpleNamespace(cfg=load(), law="lyapunov", estimator="observer")
    return SimpleNamespace(loop=loop, signal=sig.__getitem__, log=v_hat, ticks=len(v_hat))


def test_the_errors_compare_the_estimate_with_the_truth_at_its_instant():
    """Row k holds the estimate at t_k and the plant's truth at t_k+1: a perfect estimate of a 370 Hz
    sine scores 0 (within the band-limiting's edge), not the one-tick lag's 2 sin(pi f dt) = 0.11."""
    from frictionrt.rt.loop.results import _estimation_errors
    cfg = load()
    dt, f = cfg.dt_s, 370.0
    k = np.arange(8400)
    U = 3e-6
    u_at = lambda t: U * np.sin(2 * np.pi * f * t)                       # noqa: E731
    v_at = lambda t: 2 * np.pi * f * U * np.cos(2 * np.pi * f * t)       # noqa: E731
    e = _estimation_errors(_fake_run(v_at(k * dt), u_at(k * dt), v_at((k + 1) * dt), u_at((k + 1) * dt),
                                     np.full(len(k), U)))
    lag = 2 * np.sin(np.pi * f * dt)
    assert lag == pytest.approx(0.1107, abs=1e-4)
    # 0.0019 measured: the band-limiting's forward-backward edge at the record's end, in the tail
    assert e["v_rel_nrmse"] < 0.005 and e["u_rel_nrmse"] < 0.005
    assert e["v_rel_sign_error"] == 0.0 and abs(e["u0_rel_error"]) < 0.005   # mean (pi/2)|u| over a tail of partial periods
    # the same log compared row by row carries the lag: what the measures are not
    from frictionrt.observer.accuracy import band_limited_truth, lyapunov_command_error, nrmse
    v_rows = band_limited_truth(v_at((k + 1) * dt), dt, 1500.0)
    assert nrmse(v_at(k * dt), v_rows) == pytest.approx(lag, rel=0.01)
    t = cfg.tracking
    rows_rms = lyapunov_command_error(v_at(k * dt), v_rows, t.F_min_N, t.F_max_N, t.eps_m_s)[0]
    assert e["fstar_rms_error_n"] < 0.1 * rows_rms
