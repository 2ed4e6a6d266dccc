"""The contact-law options of the discrepancy effects (docs/plant.md, "Contact law"): Stribeck
friction (plant.interface.static_excess) and the Iwan element (plant.interface.iwan_spread).
Golden values are the laws' closed forms; with the options off the plant is the Jenkins plant
(byte-identity: tests/test_kernels_reference.py against the NumPy reference)."""
import numpy as np
import pytest

from plant.contact import _jenkins_pair, _stribeck_mu
from plant.energy import balance
from plant.impulse import hammer_force
from plant.model import build_plant
from rt.config import load

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
