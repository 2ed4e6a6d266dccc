"""The contact-law options of the discrepancy effects (docs/plant.md, "Contact law"): Stribeck
friction (plant.interface.static_excess) and the Iwan element (plant.interface.iwan_spread).
Golden values are the laws' closed forms; with the options off the plant is the Jenkins plant
(byte-identity: tests/test_kernels_reference.py against the NumPy reference)."""
import numpy as np
import pytest

from frictionrt.plant.contact import _jenkins_pair, _stribeck_mu
from frictionrt.plant.energy import balance
from frictionrt.plant.impulse import hammer_force
from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import load

S, V_S, MU_K = 0.3, 1e-3, 0.4


def test_stribeck_breakaway_at_mu_s_and_sliding_at_mu_k_under_imposed_motion():
    """One pair, f_n = 100 N, g_t imposed: at rest, then a ramp at v0 = 20 v_s, with mu taken
    from the velocity of the previous step (the plant's lag). The pair breaks away at
    mu_s f_n = (1 + s) mu_k f_n and then slides at mu_k f_n (exp(-400) of s left)."""
    k_n, k_t, f_n, h = 1e9, 8e8, 100.0, 1e-6
    v0 = 20 * V_S
    t = np.arange(4000) * h
    g_t = np.where(t > 1e-3, v0 * (t - 1e-3), 0.0)
    w, v, f = 0.0, 0.0, np.empty_like(t)
    for i, gt in enumerate(g_t):
        mu = _stribeck_mu(MU_K, S, v, V_S)
        _, lt, w, _, _, _ = _jenkins_pair(-f_n / k_n, gt, w, k_n, k_t, mu)
        f[i] = -lt
        v = (gt - g_t[i - 1]) / h if i else 0.0
    # largest force: the breakaway, at most one step of k_t v0 h = 16 mN past mu_s f_n = 52 N
    assert f.max() == pytest.approx((1 + S) * MU_K * f_n, abs=k_t * v0 * h)
    assert f[-1] == pytest.approx(MU_K * f_n, rel=1e-12)


def test_stribeck_plant_slides_on_the_lagged_coefficient_and_balances_energy():
    """500 N hammer at F_N1 = 40 N with s = 0.3: every pair slipping at the end of a step has
    |f_t| = mu(v) f_n with v = G_t qd at the start of the step (one substep), to round-off; the
    ratios span mu_k (fast slip) to near mu_s (breakaway: measured 1.283 mu_k, the stuck pairs'
    elastic velocity lowers it); the energy balance closes to round-off (measured 1e-14 J of
    0.039 J)."""
    cfg = load(sets=[f"plant.interface.static_excess={S}"])
    m = build_plant(cfg)
    P, sl, idx = m.params, m.state_slots(), m.output_index()
    n = int(0.05 / cfg.dt_s)
    F = hammer_force(n, cfg.dt_s, 500.0, 0.5e-3)
    x = m.initial_state(40.0)
    x0, xn, wk = x.copy(), np.empty_like(x), m.new_work()
    y = np.empty(len(m.output_labels()))
    i_fn = [idx[f"f_n_{j}"] for j in range(m.n_pairs)]
    i_ft = [idx[f"f_t_{j}"] for j in range(m.n_pairs)]
    ratio, mu_v = [], []
    for k in range(n):
        v = P.G[1::2] @ x[sl["qd"]]
        assert m.step(k, x, np.array([F[k], 40.0]), xn, y, wk) >= 0
        f_n, f_t = y[i_fn], y[i_ft]
        for j in np.flatnonzero((xn[sl["w"]] != x[sl["w"]]) & (f_n > 0)):
            ratio.append(abs(f_t[j]) / f_n[j])
            mu_v.append(_stribeck_mu(P.mu[j], S, v[j], V_S))
        x, xn = xn, x
    ratio, mu_v = np.array(ratio), np.array(mu_v)
    assert len(ratio) > 100
    np.testing.assert_allclose(ratio, mu_v, rtol=1e-13)
    assert ratio.min() < MU_K * (1 + 0.01 * S) and ratio.max() > MU_K * (1 + 0.9 * S)
    b = balance(m, x0, x)
    assert b["E_fric"] > 0.05 * b["W_exc"]
    assert abs(b["residual"]) < 1e-9 * b["W_exc"]


def _iwan_cycle_energy(x0, f_n, a, N, k_t=8e8, mu=MU_K, k_n=1e9, n=20000):
    """Imposed g_t = x0 sin(2 pi t) on one Iwan pair (kernel law, the previous step's code as the
    cached pattern): loop area of f_t over g_t in the second cycle [J], and the element arrays."""
    from frictionrt.plant.contact import _iwan_pair
    from frictionrt.plant.model import iwan_fractions
    fr = iwan_fractions(load(sets=[f"plant.interface.iwan_spread={a}", f"plant.interface.iwan_elements={N}"]))
    kf, qf = fr["iwan_k"], fr["iwan_q"]
    t = np.linspace(0.0, 2.0, 2 * n + 1)
    g_t = x0 * np.sin(2 * np.pi * t)
    w, w_new = np.zeros(N), np.zeros(N)
    f, code = np.empty_like(t), -1
    for i, gt in enumerate(g_t):
        _, lt, _, _, code = _iwan_pair(-f_n / k_n, gt, w, w_new, 0, k_n, k_t, mu, kf, qf, code, 1e-13)
        w[:] = w_new
        f[i] = -lt
    sl = slice(n, 2 * n + 1)
    return np.trapezoid(f[sl], g_t[sl]), k_t * kf, mu * f_n * qf


@pytest.mark.parametrize("a, N", [(0.5, 6), (0.9, 4), (0.3, 8)])
def test_iwan_energy_per_cycle_is_the_sum_of_its_jenkins_loops(a, N):
    """Dissipation per cycle of amplitude x0 = sum over elements with k_i x0 > q_i of
    4 q_i (x0 - q_i / k_i) (each element's Jenkins loop); amplitudes from below micro-slip (no
    loss) through partial slip to macro-slip (the 20000-point trapezoid of a piecewise-linear
    loop: ~1e-4)."""
    k_t, f_n = 8e8, 500.0
    x_macro = MU_K * f_n / k_t   # 0.25 um: all elements slip above (1 + a (N-1)/N) x_macro
    for x0 in np.array([0.3, 0.7, 1.0, 1.3, 3.0]) * x_macro:
        E, k_i, q_i = _iwan_cycle_energy(x0, f_n, a, N, k_t)
        slips = k_i * x0 > q_i
        expected = float(np.sum(4 * q_i[slips] * (x0 - q_i[slips] / k_i[slips])))
        if not slips.any():
            assert abs(E) < 1e-9 * k_t * x0**2
        else:
            assert E == pytest.approx(expected, rel=2e-3), (x0 / x_macro, slips.sum())
    # the same stiffness and macro-slip force as the Jenkins element: sum k_i = k_t, sum q_i = mu f_n
    assert k_i.sum() == pytest.approx(k_t, rel=1e-14) and q_i.sum() == pytest.approx(MU_K * f_n, rel=1e-14)
    # micro-slip starts at (1 - a (N-1)/N) of the macro-slip displacement
    assert q_i[0] / k_i[0] == pytest.approx((1 - a * (N - 1) / N) * x_macro, rel=1e-12)


def test_iwan_plant_matches_the_sum_of_jenkins_elements_and_balances_energy():
    """500 N hammer at F_N1 = 40 N, iwan_spread 0.5 (6 elements): per step the kernel's f_t and
    sliders equal the design-time law summed from its Jenkins elements (plant.model.contact_forces,
    plain _jenkins_pair per element) at the step's gaps and start sliders (measured 1e-13 N,
    1e-21 m); the state holds 6 sliders per pair; the energy balance closes (measured 4e-14 J of
    0.039 J) and the pairs dissipate."""
    from frictionrt.plant.model import contact_forces
    from frictionrt.plant.simulate import run
    cfg = load(sets=["plant.interface.iwan_spread=0.5"])
    m = build_plant(cfg)
    sl, idx = m.state_slots(), m.output_index()
    assert m.n_sliders == 6 and sl["w"].stop - sl["w"].start == 6 * m.n_pairs
    n = int(0.1 / cfg.dt_s)
    F = hammer_force(n, cfg.dt_s, 500.0, 0.5e-3)
    x = m.initial_state(40.0)
    x0, xn, wk = x.copy(), np.empty_like(x), m.new_work()
    y = np.empty(len(m.output_labels()))
    i_ft = [idx[f"f_t_{j}"] for j in range(m.n_pairs)]
    for k in range(n // 5):
        assert m.step(k, x, np.array([F[k], 40.0]), xn, y, wk) >= 0
        lam, w_new, _ = contact_forces(m, xn[sl["g"]], x[sl["w"]])
        np.testing.assert_allclose(y[i_ft], -lam[1::2], rtol=0, atol=1e-9)
        np.testing.assert_allclose(xn[sl["w"]], w_new, rtol=0, atol=1e-18)
        x, xn = xn, x
    _, x, _ = run(m, F[n // 5:], 40.0, x0=x)
    b = balance(m, x0, x)
    assert b["E_fric"] > 0.1 * b["W_exc"]
    assert abs(b["residual"]) < 1e-9 * b["W_exc"]
