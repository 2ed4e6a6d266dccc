"""The step-sine measurement of benchmarks.se_fine_stepsine on signals whose answer is known: the
accelerance's fit over a block and the peak's parabola."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.se_fine_stepsine import block_ticks, fit_H, peak_of, stepped_sine


def test_fit_recovers_a_known_accelerance_with_an_offset():
    dt = 1 / 21000
    f, amp, H = 372.0, 5.0, 16.6 * np.exp(-1j * 0.7)
    t = np.arange(block_ticks(f, dt)) * dt
    # force amp sin(w t) = Im(amp e^{i w t}); the response Im(H amp e^{i w t}) plus a constant
    acc = np.imag(H * amp * np.exp(2j * np.pi * f * t)) + 0.3
    assert fit_H(acc, f, t, amp) == pytest.approx(H, rel=1e-9)


def test_peak_of_a_parabola_is_its_vertex():
    f = np.linspace(600.0, 630.0, 7)
    rows = [{"f_hz": x, "H_abs": 50.0 - 0.1 * (x - 617.3) ** 2} for x in f]
    fp, Hp, k = peak_of(rows)
    assert fp == pytest.approx(617.3, abs=1e-9) and Hp == pytest.approx(50.0, abs=1e-9) and k == 3


def test_stepped_sine_settles_on_a_linear_oscillator():
    """A damped oscillator (exact discrete update) driven through stepped_sine: |H| at each line
    against the analytic accelerance w^2 / |w0^2 - w^2 + 2 i zeta w0 w| to 2 % (the settle tolerance)."""
    dt, w0, zeta = 1 / 21000, 2 * np.pi * 400.0, 0.05
    A = np.array([[0.0, 1.0], [-w0 ** 2, -2 * zeta * w0]])
    from scipy.linalg import expm
    Phi = expm(A * dt)
    Gam = np.linalg.solve(A, (Phi - np.eye(2)) @ np.array([0.0, 1.0]))   # zero-order hold of the force

    def run_block(x, U):
        acc = np.empty(len(U))
        for k, (F, _) in enumerate(U):
            x = Phi @ x + Gam * F
            acc[k] = -w0 ** 2 * x[0] - 2 * zeta * w0 * x[1] + F
        return x, acc
    freqs = np.array([380.0, 400.0, 420.0])
    rows, _ = stepped_sine(run_block, np.zeros(2), freqs, 1.0, dt, 0.005, 0.5)
    w = 2 * np.pi * freqs
    exact = w ** 2 / np.abs(w0 ** 2 - w ** 2 + 2j * zeta * w0 * w)
    got = np.array([r["H_abs"] for r in rows])
    assert all(r["settled"] for r in rows)
    np.testing.assert_allclose(got, exact, rtol=0.02)
