"""The amplitude-following observer (observer/amplitude.py, observer/amplitude_step.py): its
blocks against the paper's discrete model, its compiled step against a plain NumPy reference,
its schedule, and the kind in the loop (replay bit-exact; its C export: tests/test_export_amplitude.py)."""
import json

import numpy as np
import pytest

from frictionrt.observer.amplitude import AMP_GRID_M, design_amplitude, frequency_ratios, mode_blocks
from frictionrt.observer.amplitude_step import _amplitude_step
from frictionrt.observer.step import _implicit_v, _observer_step
from frictionrt.plant.model import build_plant
from frictionrt.rt.cli import main
from frictionrt.rt.common.config import load


@pytest.fixture(scope="module")
def designs():
    cfg = load()
    plant = build_plant(cfg)
    return (design_amplitude(cfg, plant, peaks={}, ratios={}), design_amplitude(cfg, plant),
            design_amplitude(cfg, plant, jenkins=True))


def _full(blocks_j, N):
    """(2N, 2N) A_d and (2N,) bd from one grid amplitude's blocks (N, 7), slots [q; q']."""
    A = np.zeros((2 * N, 2 * N))
    B = np.zeros(2 * N)
    for i in range(N):
        s = [i, N + i]
        A[np.ix_(s, s)] = blocks_j[i, :4].reshape(2, 2)
        B[s] = blocks_j[i, 4:6]
    return A, B


def test_blocks_at_ratio_one_are_the_papers_discrete_model(designs):
    """With r = 1 the blocks are the paper's A_d and B_dT (both exact ZOH of the same model: expm
    of 3 x 3 against cont2discrete's 15 x 15, round-off apart), and A_d has nothing outside them."""
    (od, ap), *_ = designs
    p = od.params
    N = len(od.model.omega)
    for j in range(len(AMP_GRID_M)):
        A, B = _full(ap.blocks[:, j], N)
        assert np.allclose(A, p.A_d, rtol=1e-12, atol=1e-12)
        assert np.allclose(B, p.B_dT, rtol=1e-11, atol=0.0)
    assert np.all(p.A_d[A == 0.0] == 0.0)


def test_mode_block_is_the_free_oscillator():
    """Undamped: the block is the closed-form rotation of (q, q'/w) by w dt, input column [0, 1]."""
    w, dt = 2 * np.pi * 380.0, 1 / 21000
    b = mode_blocks(w, 0.0, 1.0, dt)
    c, s = np.cos(w * dt), np.sin(w * dt)
    assert np.allclose(b[:4], [c, s / w, -w * s, c], rtol=1e-13, atol=1e-13)
    assert b[4] == pytest.approx((1 - c) / w**2, rel=1e-9) and b[5] == pytest.approx(s / w, rel=1e-12)


def test_ratios_follow_the_peaks_and_hold_beyond():
    r = frequency_ratios(7, (0.0, 1e-6, 2e-6, 8e-6), {4: ((2e-6, 0.98), (4e-6, 0.97))})
    assert np.all(r[[0, 1, 2, 4, 5, 6]] == 1.0)
    assert np.allclose(r[3], [1.0, 0.99, 0.98, 0.97])


def _reference_step(x, u, p, a):
    """The step in plain NumPy (amplitude_step's docstring), full 2N matrices; with the Jenkins
    joint (a.k_j > 0) the slider is x[2N] and the force the spring's, clamped at mu |F_N|."""
    n = len(p.M)
    N = n // 2
    jen = a.k_j > 0
    e = u[0] - p.C_meas @ x[:n]
    z = x[:n] + p.M * e
    blk = np.empty((N, 7))
    for i in range(N):
        amp = a.scale[i] * np.hypot(z[i], z[N + i] * a.inv_omega[i])
        blk[i] = [np.interp(amp, a.grid, a.blocks[i, :, m]) for m in range(7)]
    p = p._replace(C_u=p.C_u * np.tile(blk[:, 6], 2), C_v=p.C_v * np.tile(blk[:, 6], 2))   # the participation
    v = p.C_v @ z
    c = p.mu * u[1] * 2 / np.pi
    q = p.mu * abs(u[1])
    f = np.clip(a.k_j * (p.C_u @ z - x[n]) / (1 - a.k_j * p.D_u), -q, q) if jen else c * np.arctan(p.alpha * v)
    y = np.array([p.C_u @ z + p.D_u * f, v, e, f])
    A, B = _full(blk, N)
    if jen:
        u_star, c_u = p.C_u @ A @ z, p.C_u @ B + p.D_u
        f = a.k_j * (u_star - x[n]) / (1 - a.k_j * c_u)
        s = x[n] if abs(f) <= q else u_star + c_u * np.clip(f, -q, q) - np.clip(f, -q, q) / a.k_j
        return np.append(A @ z + B * np.clip(f, -q, q), s), y
    v_next = _implicit_v(p.C_v @ A @ z, p.C_v @ B, u[1], p.mu, p.alpha)
    return A @ z + B * c * np.arctan(p.alpha * v_next), y


@pytest.mark.parametrize("jenkins", [False, True])
def test_step_against_numpy_reference(designs, jenkins):
    """The compiled step against the reference on states spread over the grid (modes 2-5 at
    0.3-40 um of u_rel: on, between and beyond the grid points), F_N 40 and 600 N, 20 draws; the
    Jenkins joint's slider within +-2 um of u_rel (both stick and slip are met: counted)."""
    od, ap = designs[2 if jenkins else 1]
    p = od.params
    N = len(od.model.omega)
    m = 2 * N + jenkins
    rng = np.random.default_rng(3)
    slipped = 0
    for _ in range(20):
        x = np.zeros(m)
        for i in range(1, 5):
            q = 10 ** rng.uniform(np.log10(0.3e-6), np.log10(40e-6)) / ap.scale[i]
            ph = rng.uniform(0, 2 * np.pi)
            x[i], x[N + i] = q * np.cos(ph), -q * od.model.omega[i] * np.sin(ph)
        if jenkins:
            x[2 * N] = od.params.C_u @ x[:2 * N] + rng.uniform(-2e-6, 2e-6)
        u = np.array([rng.normal(0, 1e-3), rng.choice([40.0, 600.0])])
        x_next, y, w = np.empty(m), np.empty(4), np.empty(2 * N)
        _amplitude_step(0, x, u, p, ap, w, x_next, y)
        x_ref, y_ref = _reference_step(x, u, p, ap)
        assert np.allclose(y, y_ref, rtol=1e-12, atol=1e-18)
        assert np.allclose(x_next, x_ref, rtol=1e-9, atol=1e-12 * np.max(np.abs(x_ref)))
        slipped += jenkins and x_next[2 * N] != x[2 * N]
    if jenkins:
        assert 0 < slipped < 20


def test_jenkins_joint_holds_below_its_slip_limit_and_slides_at_it(designs):
    """The joint stuck (F_N large): the slider stays and the force is the spring's, |f| < mu F_N;
    F_N = 0: no force, the slider follows u_rel (it slides freely)."""
    od, ap = designs[2]
    p = od.params
    n = len(p.M)
    x = np.zeros(n + 1)
    x[3] = 2e-6 / ap.scale[3]
    xn, y, w = np.empty(n + 1), np.empty(4), np.empty(n)
    _amplitude_step(0, x, np.array([0.0, 1e6]), p, ap, w, xn, y)
    assert xn[n] == 0.0 and 0.0 < abs(y[3]) < p.mu * 1e6
    _amplitude_step(0, x, np.array([0.0, 0.0]), p, ap, w, xn, y)
    assert y[3] == 0.0 and xn[n] == pytest.approx(p.C_u @ xn[:n], rel=1e-12)


def test_flat_schedule_is_the_papers_step(designs):
    """r = 1: the paper's observer: the same outputs bit for bit (the same arithmetic), the next
    state to the round-off of the block-wise product."""
    (od, ap), *_ = designs
    p = od.params
    n = len(p.M)
    x = np.random.default_rng(5).normal(0, 1e-4, n)
    u = np.array([2e-3, 300.0])
    xa, ya, w = np.empty(n), np.empty(4), np.empty(n)
    xo, yo = np.empty(n), np.empty(4)
    _amplitude_step(0, x, u, p, ap, w, xa, ya)
    _observer_step(0, x, u, p, xo, yo)
    assert np.array_equal(ya, yo)
    assert np.allclose(xa, xo, rtol=1e-10, atol=1e-12 * np.max(np.abs(xo)))


def test_error_dynamics_stable_at_every_grid_amplitude(designs):
    """The paper's gain with every mode at its scheduled frequency: spectral radius < 1."""
    _, (od, ap), _ = designs
    p = od.params
    N = len(od.model.omega)
    I_MC = np.eye(2 * N) - np.outer(p.M, p.C_meas)
    for j in range(len(ap.grid)):
        A, _ = _full(ap.blocks[:, j], N)
        assert np.max(np.abs(np.linalg.eigvals(A @ I_MC))) < 1.0


@pytest.fixture(scope="module")
def amp_log(tmp_path_factory):
    d = tmp_path_factory.mktemp("amp")
    code = main(["simulate", "--law", "hysteresis", "--estimator", "amplitude", "--freq", "374.97", "--amp", "5",
                 "--duration", "0.1", "--out", str(d / "amp"), "--no-rrd", "--json"])
    assert code == 0
    return d / "amp.mcap"


def test_replay_of_the_amplitude_kind_is_bit_exact(amp_log, capsys):
    capsys.readouterr()
    code = main(["replay", str(amp_log), "--json"])
    r = json.loads(capsys.readouterr().out)
    assert code == 0 and r["bit_exact"] is True and r["max_abs_diff"] == 0.0
    assert (r["estimator"], r["ticks"]) == ("amplitude", 2100)
    assert r["outputs"]["V_cmd"]["max"] > r["outputs"]["V_cmd"]["min"]


def test_supervisor_catches_a_diverging_amplitude_observer():
    """The supervisor's observer checks run on this kind: a state mismatch injected at 0.05 s is
    observer_divergence within 5 ticks (as for the paper's observer), the loop then passive."""
    from frictionrt.rt.loop import build_loop, run, summary
    from frictionrt.rt.loop.faults import schedule
    from frictionrt.rt.loop.supervisor import FAULT_CODES
    cfg = load()
    r = run(build_loop(cfg, "lyapunov", "amplitude"), 196.0, 5.0, 0.08,
            faults=schedule(["observer_mismatch@0.05"], cfg))
    f = summary(r)["faults"][0]
    assert f["name"] == "observer_divergence" and FAULT_CODES[f["code"]] == f["name"]
    assert 0 <= f["detected_tick"] - 1050 <= 5 and f["passive_tick"] - f["detected_tick"] <= 1
    assert r.signal("passive")[f["passive_tick"]:].all()
