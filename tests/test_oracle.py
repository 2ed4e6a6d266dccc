"""The band-limited oracle estimator against scipy's own filter."""
import numpy as np
import pytest
import scipy.signal as ss

from frictionrt.observer.oracle import ORACLE_SLOTS, build_oracle
from frictionrt.tracking.lowpass import _biquad_step as _oracle_step
from frictionrt.tracking.lowpass import rest_state
from frictionrt.rt.common.config import load


def test_oracle_equals_scipy_sosfilt():
    cfg = load()
    p = build_oracle(cfg)
    rng = np.random.default_rng(1)
    n = 3000
    u = np.column_stack([1e-6 * rng.normal(size=n), 1e-3 * rng.normal(size=n)])
    x, x_next, y = np.zeros(len(ORACLE_SLOTS)), np.zeros(len(ORACLE_SLOTS)), np.zeros(2)
    out = np.empty((n, 2))
    for k in range(n):
        _oracle_step(k, x, u[k], p, x_next, y)
        x[:] = x_next
        out[k] = y
    sos = ss.butter(2, cfg.observer.oracle_bandwidth_hz, fs=1 / cfg.dt_s, output="sos")
    for j in range(2):
        ref = ss.sosfilt(sos, u[:, j])
        # same recursion in another order of operations: agreement to round-off
        assert np.max(np.abs(out[:, j] - ref)) <= 1e-12 * np.max(np.abs(ref))


def test_oracle_gain_and_steady_state():
    cfg = load()
    p = build_oracle(cfg)
    x = rest_state(p, (2e-6, 3e-3))
    x_next, y = np.zeros_like(x), np.zeros(2)
    _oracle_step(0, x, np.array([2e-6, 3e-3]), p, x_next, y)
    np.testing.assert_allclose(y, [2e-6, 3e-3], rtol=1e-12)  # DC gain 1, started at rest
    np.testing.assert_allclose(x_next, x, rtol=1e-12)
    # a 223 Hz sine passes within 1 %; near-Nyquist ringing (8 kHz) is attenuated > 30x
    sos = ss.butter(2, cfg.observer.oracle_bandwidth_hz, fs=1 / cfg.dt_s, output="sos")
    _, h = ss.sosfreqz(sos, worN=[223.6, 8000.0], fs=1 / cfg.dt_s)
    assert abs(abs(h[0]) - 1) < 0.01 and abs(h[1]) < 1 / 30


def test_oracle_bandwidth_above_nyquist_is_refused():
    with pytest.raises(ValueError, match="observer.oracle_bandwidth_hz = 12000 Hz.*Nyquist"):
        build_oracle(load(sets=["observer.oracle_bandwidth_hz=12000"]))
