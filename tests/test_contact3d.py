"""The 3-D contact point law (plant.contact3d): analytic dissipation, the exact radial return, the
1-D limit, the tangent. Golden values from the Jenkins element's closed forms, not from the code."""
from __future__ import annotations

import math

import numpy as np
import pytest

from frictionrt.plant.contact import _jenkins_pair
from frictionrt.plant.contact3d import _coulomb_disc

K_N, K_T, MU = 2e8, 1.6e8, 0.4
G_N = -5e-7                     # closed: f_n = 100 N, slip limit 40 N, delta = limit / k_t = 0.25 um


def _law(g, w_old, nt=2):
    lam, w_new, D = np.zeros(1 + nt), np.zeros(nt), np.zeros((1 + nt) ** 2)
    code = _coulomb_disc(np.asarray(g, float), 0, nt, np.asarray(w_old, float), 0, K_N, K_T, MU, lam, 0, w_new, D, 0)
    return code, lam, w_new, D.reshape(1 + nt, 1 + nt)


def _cycle_dissipation(path):
    """Friction work sum f_t . dw over a closed tangential path (second pass: the steady cycle)."""
    w = np.zeros(2)
    e = 0.0
    for rep in range(2):
        e = 0.0
        for gt in path:
            _, lam, w_new, _ = _law([G_N, *gt], w)
            e += -lam[1:] @ (w_new - w)
            w = w_new
    return e


def test_stick_slip_cycle_dissipates_4_mu_fn_times_slip():
    """Harmonic slip of amplitude x0 along an oblique direction: E = 4 mu f_n (x0 - mu f_n / k_t) per cycle
    (Jenkins element, exact for a path whose reversals are samples)."""
    f_n = -K_N * G_N
    x0 = 1e-6
    phi = math.radians(30.0)
    t = np.arange(2000) / 2000
    path = np.outer(x0 * np.cos(2 * np.pi * t), [math.cos(phi), math.sin(phi)])
    exact = 4 * MU * f_n * (x0 - MU * f_n / K_T)
    assert _cycle_dissipation(path) == pytest.approx(exact, rel=1e-12)


def test_circular_slip_dissipates_2pi_mu_fn_sqrt_r2_minus_delta2():
    """Steady circular slip of radius r: the slider trails on the circle of radius sqrt(r^2 - delta^2) with
    the force tangent to it (normality), so E = 2 pi mu f_n sqrt(r^2 - delta^2) per turn; a law with a
    square (two independent 1-D) limit gives a different figure. The return is backward Euler along the
    curved path: first order in the angle step (-0.81 / n per turn of n steps), so the Richardson
    extrapolation of n = 500 and 1000 must hit the closed form."""
    f_n = -K_N * G_N
    delta = MU * f_n / K_T
    r = 1e-6
    exact = 2 * np.pi * MU * f_n * math.sqrt(r * r - delta * delta)
    e = []
    for n in (500, 1000):
        th = 2 * np.pi * np.arange(n) / n
        e.append(_cycle_dissipation(r * np.column_stack([np.cos(th), np.sin(th)])))
    assert e[1] == pytest.approx(exact, rel=1e-3)
    assert 2 * e[1] - e[0] == pytest.approx(exact, rel=1e-5)   # 2.6e-6: the second-order remainder


def test_radial_return_is_the_closest_point_projection_on_an_oblique_path():
    """From a stuck state, a trial force outside the disc returns to the point of the circle nearest to it
    (the exact implicit solution for the circular cone): force mu f_n along f*, slip increment parallel to
    the force (normality), and a straight oblique path ends with the force along the path."""
    f_n = -K_N * G_N
    w0 = np.array([0.1e-6, -0.2e-6])
    gt = np.array([1.3e-6, 0.4e-6])
    code, lam, w_new, _ = _law([G_N, *gt], w0)
    f_star = K_T * (gt - w0)
    f = -lam[1:]
    assert code == 2
    np.testing.assert_allclose(f, MU * f_n * f_star / np.linalg.norm(f_star), rtol=1e-14)
    # nearest point of the disc to f*, independently: brute force over the circle's angle
    ang = np.linspace(0, 2 * np.pi, 200001)
    pts = MU * f_n * np.column_stack([np.cos(ang), np.sin(ang)])
    best = pts[np.argmin(np.linalg.norm(pts - f_star, axis=1))]
    np.testing.assert_allclose(f, best, atol=MU * f_n * 4e-5)
    dw = w_new - w0
    assert abs(dw[0] * f[1] - dw[1] * f[0]) <= 1e-12 * np.linalg.norm(dw) * np.linalg.norm(f)
    assert dw @ f > 0
    # straight path at 60 degrees from rest: after gross slip the force points along the path
    e = np.array([0.5, math.sqrt(0.75)])
    w = np.zeros(2)
    for s in np.linspace(0, 3e-6, 301):
        _, lam, w, _ = _law([G_N, *(s * e)], w)
    np.testing.assert_allclose(-lam[1:], MU * f_n * e, rtol=1e-13)


def test_one_direction_is_the_jenkins_element():
    rng = np.random.default_rng(3)
    for _ in range(200):
        g_n, g_t, w = rng.normal(-2e-7, 5e-7), rng.normal(0, 1e-6), rng.normal(0, 5e-7)
        code, lam, w_new, D = _law([g_n, g_t], [w], nt=1)
        ln, lt, wn, dnn, dtn, dtt = _jenkins_pair(g_n, g_t, w, K_N, K_T, MU)
        np.testing.assert_allclose([lam[0], lam[1], w_new[0]], [ln, lt, wn], rtol=1e-15, atol=1e-24)
        np.testing.assert_allclose([D[0, 0], D[1, 0], D[1, 1]], [dnn, dtn, dtt], rtol=1e-15)


@pytest.mark.parametrize("g,w", [([G_N, 1e-7, 0.5e-7], [0.0, 0.0]),         # stick
                                 ([G_N, 1.2e-6, -0.7e-6], [0.1e-6, 0.0])])  # slip
def test_tangent_is_the_derivative(g, w):
    g = np.array(g)
    _, lam0, _, D = _law(g, w)
    for j in range(3):
        e = 1e-6 * (abs(g[j]) + 1e-7)
        gp, gm = g.copy(), g.copy()
        gp[j] += e
        gm[j] -= e
        fd = (_law(gp, w)[1] - _law(gm, w)[1]) / (2 * e)
        np.testing.assert_allclose(D[:, j], fd, rtol=1e-6, atol=1e-6 * K_N)


def test_open_point_carries_nothing_and_relaxes_its_spring():
    code, lam, w_new, D = _law([1e-9, 3e-7, -2e-7], [0.0, 0.0])
    assert code == 0 and not lam.any() and not D.any()
    np.testing.assert_array_equal(w_new, [3e-7, -2e-7])
