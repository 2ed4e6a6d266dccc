"""The Kalman-designed nonlinear observer (issue 4): design checks, the compiled step against
python-control's simulation of the same discrete observer, stability with stiff friction, and
its accuracy in the closed loop against the plant's truth."""
import warnings

import control
import numpy as np
import pytest
import scipy.linalg as sla
import scipy.optimize as so

from frictionrt.observer.kalman import design_observer, discrete_eigenvalues
from frictionrt.observer.model import build_observer_model
from frictionrt.observer.step import _observer_step
from frictionrt.plant.structure import build_structure, interface_rows
from frictionrt.plant.modes import passive_resonance_hz
from frictionrt.rt.common.config import load
from frictionrt.rt.loop import COMPONENTS, build_loop, run, summary

BUDGET_US = 1e6 / 21000


@pytest.fixture(scope="module")
def design():
    return design_observer(load())


def test_error_dynamics_stable_and_gain_forms_agree(design):
    p = design.params
    C = p.C_meas[None, :]
    # python-control's own view of the design: A_d - L C strictly inside the unit circle
    E = np.linalg.eigvals(p.A_d - np.outer(design.L, p.C_meas))
    assert np.max(np.abs(E)) < 1.0
    # the filter gain M and the predictor gain L = A_d M describe the same filter
    np.testing.assert_allclose(p.A_d @ p.M, design.L, rtol=1e-9, atol=1e-14)
    # M = P C^T / (C P C^T + R) with dlqe's a-priori covariance
    np.testing.assert_allclose(p.M, (design.P @ C.T).ravel() / ((C @ design.P @ C.T)[0, 0] + design.R), rtol=1e-12)


def test_static_correction_completes_the_truncated_compliance():
    # static u_rel under a friction force f: truncated modal model + D_u f must equal the
    # full FE static solution of the tied structure (computed independently here)
    cfg = load()
    m = build_observer_model(cfg)
    N = len(m.omega)
    f = 10.0
    q = -m.C_u[:N] * f / m.omega**2  # modal static response to the generalised force -t^T f
    u_model = m.C_u[:N] @ q + m.D_u * f
    st = build_structure(cfg)
    K = sla.block_diag(*(s.K for s in st.subs))
    itf = cfg.plant.interface
    b = min(beam.width_m for beam in cfg.plant.beams)
    for x, length in zip(m.x_tied, m.l_tied):
        r_n, r_t = interface_rows(cfg, st.subs, x)
        K += b * length * (itf.k_n_area * np.outer(r_n, r_n) + itf.k_t_area * np.outer(r_t, r_t))
    for x, length in zip(m.x_springs, m.l_springs):
        r_n, _ = interface_rows(cfg, st.subs, x)
        K += b * length * itf.k_n_area * np.outer(r_n, r_n)
    u_full = st.u_rel_row @ np.linalg.solve(K, -st.u_rel_row * f)
    assert u_model == pytest.approx(u_full, rel=1e-9)
    assert abs(m.D_u * f) > 0.05 * abs(u_full)  # the correction matters (7 modes miss > 5 %)


def test_friction_implicit_stable_explicit_would_not_be(design):
    # default alpha (100 s/m): stable both ways; a sharper friction (alpha = 2000 s/m, slope
    # 1.5e5 N s/m at F_max) is stable only with the implicit step the observer uses
    F_max = load().tracking.F_max_N
    sharp = design_observer(load(sets=["observer.alpha_s_m=2000"]))
    for d in (design, sharp):
        for F in np.linspace(0.0, F_max, 5):
            assert np.max(np.abs(discrete_eigenvalues(d, F))) < 1.0
    assert np.max(np.abs(discrete_eigenvalues(design, F_max, implicit=False))) < 1.0
    assert np.max(np.abs(discrete_eigenvalues(sharp, F_max, implicit=False))) > 1.5


def _reference_observer(p):
    """The same discrete observer written independently with NumPy and scipy's brentq."""
    def fr(v, F):
        return p.mu * F * (2 / np.pi) * np.arctan(p.alpha * v)

    def filtered(z, u):
        e = u[0] - p.C_meas @ z
        return z + p.M * e, e

    def upd(t, z, u, params):
        zf, _ = filtered(z, u)
        v_star = p.CvA @ zf
        if v_star == 0.0:
            v = 0.0
        else:
            v = so.brentq(lambda v: v - p.beta * fr(v, u[1]) - v_star, min(0.0, v_star), max(0.0, v_star),
                          xtol=1e-300, rtol=4 * np.finfo(float).eps)
        return p.A_d @ zf + p.B_dT * fr(v, u[1])

    def out(t, z, u, params):
        zf, e = filtered(z, u)
        v = p.C_v @ zf
        f = fr(v, u[1])
        return np.array([p.C_u @ zf + p.D_u * f, v, e, f])
    return upd, out


def test_compiled_step_equals_python_control_simulation(design):
    p = design.params
    dt = design.dt
    n = 600
    t = np.arange(n) * dt
    v_tip = 0.03 * np.sin(2 * np.pi * 200 * t) + 0.01 * np.sin(2 * np.pi * 385 * t + 1) + 0.005 * np.sin(2 * np.pi * 71 * t)
    F_N = 320 + 280 * np.sign(np.sin(2 * np.pi * 230 * t))  # bang-bang 40 / 600 N
    U = np.vstack([v_tip, F_N])
    upd, out = _reference_observer(p)
    sys = control.nlsys(upd, out, inputs=2, outputs=4, states=len(p.M), dt=dt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = control.input_output_response(sys, t, U, X0=np.zeros(len(p.M)))
    x, xn, y = np.zeros(len(p.M)), np.zeros(len(p.M)), np.zeros(4)
    Y = np.empty((4, n))
    for k in range(n):
        _observer_step(k, x, U[:, k].copy(), p, xn, y)
        Y[:, k] = y
        x, xn = xn, x
    for i in range(4):
        scale = np.max(np.abs(ref.outputs[i]))
        assert scale > 0
        assert np.max(np.abs(Y[i] - ref.outputs[i])) <= 1e-9 * scale, f"output {i}"


@pytest.mark.timing
def test_observer_timing_share_of_the_budget():
    # robust: the estimator's median well inside a tenth of the budget (target 0.2 us lives in
    # `frictionrt budget`); the whole tick's median still far below the budget
    r = run(build_loop(load(), "hysteresis", "observer"), 200.0, 5.0, 0.5, timing=True)
    med = np.median(r.comp_ns, axis=0) / 1e3
    est = med[COMPONENTS.index("estimator")]
    print(f"\n[observer] estimator median {est:.3f} us, tick median {np.median(r.signal('tick_ns')) / 1e3:.2f} us")
    assert est < BUDGET_US / 10
    assert np.median(r.signal("tick_ns")) / 1e3 < BUDGET_US / 4


# --- closed loop: accuracy against the plant's truth, the laws with the observer, robustness --

# passive (F_N1 = 40 N) resonances of modes 3 and 4 from the model's own modes (205.1, 380.1 Hz)
F3, F4 = passive_resonance_hz(load(), 3), passive_resonance_hz(load(), 4)


def test_accuracy_at_the_mode3_and_mode4_resonances(capsys):
    # hysteresis-optimal law on the observer, 1 s runs, steady state over the last 20 %:
    # NRMSE(v_rel) <= 0.3 against the plant's band-limited truth (issue 4, check 2)
    loop = build_loop(load(), "hysteresis", "observer")
    rows = []
    for f in (F3, F4):
        for amp in (5.0, 10.0):
            s = summary(run(loop, f, amp, 1.0))
            rows.append((f, amp, s["v_rel_nrmse"], s["u_rel_nrmse"], s["u0_rel_error"]))
    with capsys.disabled():
        print("\n[observer accuracy, hysteresis] f [Hz], F [N], NRMSE v_rel, NRMSE u_rel, u0 error")
        for r in rows:
            print(f"  {r[0]:6.1f} {r[1]:5.1f}  {r[2]:.3f}  {r[3]:.3f}  {100 * r[4]:+.1f} %")
    for f, amp, nv, nu, e0 in rows:
        # 0.3 at 5 N (issue 4); measured on the 10 mm plant of issue 31 0.192 and 0.284 (20 mm:
        # 0.216, 0.283). At 10 N mode 4 sits at 0.364 (20 mm: 0.300), so the bound there is 0.40 (the
        # regularised friction misses more of the stick-slip; the observer is re-tuned for the new
        # plant by the next issue). u0: measured +4.6..+15.0 %
        assert nv <= (0.3 if amp == 5.0 else 0.40), f"{f} Hz, {amp} N: NRMSE v_rel {nv:.3f}"
        assert abs(e0) <= 0.18, f"{f} Hz, {amp} N: u0 error {100 * e0:+.1f} %"


def _peak(loop, freqs, amp=5.0):
    return max(summary(run(loop, f, amp, 1.0))["acc045_amplitude"] for f in freqs)


def test_laws_on_the_observer_reduce_the_mode3_peak(capsys):
    # issue 4, check 4 (mode 3): the peak over 193..199 Hz of each law on the observer against
    # passive F_N1 = 40 N; Lyapunov also at mode 4 (the hysteresis law at 5 N stiffens the joint
    # and moves mode 4 up onto the scan: docs/observer.md, where the full table is)
    cfg = load()
    freqs = (F3 - 3, F3, F3 + 3)
    passive = _peak(build_loop(cfg, "passive"), freqs)
    hyst = _peak(build_loop(cfg, "hysteresis", "observer"), freqs)
    lyap = _peak(build_loop(cfg, "lyapunov", "observer"), freqs)
    passive4 = _peak(build_loop(cfg, "passive"), (F4,))
    lyap4 = _peak(build_loop(cfg, "lyapunov", "observer"), (F4,))
    with capsys.disabled():
        print(f"\n[observer, 5 N] mode-3 peak: passive {passive:.2f}, hysteresis {hyst:.2f}, lyapunov {lyap:.2f} m/s^2; "
              f"mode 4 at {F4:g} Hz: passive {passive4:.2f}, lyapunov {lyap4:.2f} m/s^2")
    # measured on the bolted plant: hysteresis -28 %, Lyapunov -56 % at mode 3, -65 % at mode 4
    # (docs/observer.md; on the plant before issue 15 the hysteresis law gave only -2.8 %)
    assert hyst < 0.99 * passive
    assert lyap < 0.7 * passive
    assert lyap4 < 0.7 * passive4


@pytest.mark.parametrize("sets, f_scale", [
    (["plant.interface.mu=0.28"], 1.0),
    (["plant.interface.mu=0.52"], 1.0),
    ([f"plant.beams.main.E={2.1e11 * 1.02**2:.6g}", f"plant.beams.damper.E={2.1e11 * 1.02**2:.6g}"], 1.02),
    ([f"plant.beams.main.E={2.1e11 * 0.98**2:.6g}", f"plant.beams.damper.E={2.1e11 * 0.98**2:.6g}"], 0.98),
    (["sensors.acc_noise_rms=0.03"], 1.0),
])
def test_observer_robust_to_model_errors(sets, f_scale):
    # issue 4, check 3: the plant differs from the observer's model (mu +-30 %, all frequencies
    # +-2 % via E, accelerometer noise x 3); the observer is designed from the nominal
    # configuration. It stays stable (finite, NRMSE < 1 with the hysteresis law) and the
    # Lyapunov law on it still reduces the mode-3 response against passive
    nominal = load()
    assert nominal.plant.beams[0].E == 2.1e11
    plant_cfg = load(sets=sets)
    f = F3 * f_scale
    s = summary(run(build_loop(plant_cfg, "hysteresis", "observer", observer_cfg=nominal), f, 5.0, 1.0))
    assert np.isfinite(s["v_rel_nrmse"]) and s["v_rel_nrmse"] < 1.0
    passive = summary(run(build_loop(plant_cfg, "passive"), f, 5.0, 1.0))["acc045_amplitude"]
    lyap = summary(run(build_loop(plant_cfg, "lyapunov", "observer", observer_cfg=nominal), f, 5.0, 1.0))
    print(f"\n[robustness {sets}] NRMSE v_rel (hysteresis) {s['v_rel_nrmse']:.3f}, "
          f"acc: passive {passive:.2f}, lyapunov {lyap['acc045_amplitude']:.2f} m/s^2")
    # measured 0.81 x passive at mu = 0.28 (the least friction), 0.64..0.72 x otherwise (docs/observer.md)
    assert lyap["acc045_amplitude"] < 0.9 * passive


def test_newton_stops_at_its_root_in_a_few_iterations(design):
    # the implicit friction step on a grid of end-of-tick velocities v* (both signs, 1e-7..1 m/s)
    # and forces up to F_max: the root to round-off against scipy's brentq, in few iterations
    # (a Newton that rejected its own converged step bisected for ~40 more)
    from frictionrt.observer.step import NEWTON_MAX, _implicit_v_iter
    p = design.params
    F_max = load().tracking.F_max_N
    its = []
    for F in np.linspace(0.0, F_max, 7):
        for v_star in np.concatenate([-np.logspace(-7, 0, 29), np.logspace(-7, 0, 29)]):
            v, n = _implicit_v_iter(v_star, p.beta, F, p.mu, p.alpha)
            g = lambda x: x - p.beta * p.mu * F * (2 / np.pi) * np.arctan(p.alpha * x) - v_star  # noqa: E731
            ref = so.brentq(g, min(0.0, v_star), max(0.0, v_star), xtol=1e-300, rtol=4 * np.finfo(float).eps)
            assert abs(v - ref) <= 1e-15 * (abs(v_star) + 1e-12) + 4 * np.spacing(abs(ref)), (F, v_star)
            its.append(n)
    its = np.array(its)
    assert its.max() <= 8 < NEWTON_MAX, np.bincount(its)
    assert np.median(its) <= 4
