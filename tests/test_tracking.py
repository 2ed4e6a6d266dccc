"""tracking/: RT1 amplitude filter, the three control laws, force tracking (FF + PID) and its
design (issue 3).

References. Every kernel is compared with a plain NumPy reference written here from the
equations in the module docstrings (SPEC 3, 4), not from the kernels' code: the RT1 filter as
``scipy.signal.lfilter`` (1 - a formed as 1 - exp(-dt/T1), not by expm1), the laws vectorised
with ``np.where``/``np.clip``, the PID as a per-tick Python loop. The closed force loop is
checked against python-control's own simulation of the same discrete system
(``control.interconnect`` + ``forced_response``), and the design figures against
``control.stability_margins``.

Tolerances.
  RTOL = 1e-12  kernel vs NumPy reference, relative to the largest magnitude of the signal
                compared (round-off of a few operations per tick; observed <= ~1e-15).
  CL_RTOL = 1e-9  njit kernel + NumPy plant vs python-control's simulation of the same
                discrete loop (issue brief): both are exact recursions of the same linear
                system in different state coordinates/orderings, so they differ by round-off
                amplified by the loop's slowest pole (|z| ~ 0.92, ~12 ticks); observed ~1e-14.
  Analytic checks state their own tolerance where they are made.
"""
from __future__ import annotations

import math
import warnings

import control
import numpy as np
import pytest
import scipy.signal as ss

from frictionrt.rt.common.config import load
from frictionrt.tracking import force_tracking as ft
from frictionrt.tracking.laws import LAW_CODES, LAWS_SLOTS, _laws_step, build_laws, laws_step
from frictionrt.tracking.rt1 import RT1_SLOTS, _rt1_step, build_rt1, rt1_step

RTOL = 1e-12
CL_RTOL = 1e-9
LN9_2PI = math.log(9.0) / (2 * math.pi)  # 10-90 % rise time x -3 dB bandwidth of a first-order lag


# --- helpers ------------------------------------------------------------------------------------

def assert_rel(got, ref, what, rtol=RTOL, scale=None):
    """max |got - ref| <= rtol * scale, scale = max |ref| unless given."""
    got, ref = np.asarray(got, float), np.asarray(ref, float)
    scale = float(np.max(np.abs(ref))) if scale is None else float(scale)
    assert scale > 0 and np.all(np.isfinite(got)), f"{what}: zero scale or non-finite values"
    err = float(np.max(np.abs(got - ref))) / scale
    assert err <= rtol, f"{what}: max |got - ref| / scale = {err:.3e} > {rtol:g}"
    return err


def run_open(step, p, x0, U, ny):
    """Step a kernel over the rows of U (inputs not fed back); returns (X [n+1, nx], Y [n, ny])."""
    X = np.empty((len(U) + 1, len(x0)))
    Y = np.empty((len(U), ny))
    X[0] = x0
    for k in range(len(U)):
        step(np.int64(k), X[k], np.ascontiguousarray(U[k]), p, X[k + 1], Y[k])
    return X, Y


def run_loop(design, p, F_set, F0_true=None, x0_plant=None, x0_ctrl=None):
    """The njit force-tracking kernel in closed loop with the discretised actuator model
    simulated step by step in NumPy: F_meas,k = F0_true + C_meas x_k; V_k = kernel(F*_k,
    F_meas,k); x_{k+1} = A x_k + B V_k (the plant has no feedthrough, D = 0).

    F0_true != p.F0 models a feedforward mismatch (the real force at 0 V differs from the
    configured F0). Returns dict of per-tick arrays and the final states."""
    G = design.plant
    A, B, C = np.asarray(G.A), np.asarray(G.B)[:, 0], np.asarray(G.C)
    assert np.all(np.asarray(G.D) == 0.0)
    F0_true = p.F0 if F0_true is None else F0_true
    n = len(F_set)
    x = np.zeros(A.shape[0]) if x0_plant is None else np.array(x0_plant, float)
    xc = ft.initial_state(F0_true + C[1] @ x) if x0_ctrl is None else np.array(x0_ctrl, float)
    xc_next, y, u = np.empty(3), np.empty(2), np.empty(2)
    out = {k: np.empty(n) for k in ("F_meas", "F", "V", "sat", "integ")}
    states = np.empty((n, A.shape[0]))
    for k in range(n):
        states[k] = x
        F_true, F_meas = F0_true + C[0] @ x, F0_true + C[1] @ x
        u[0], u[1] = F_set[k], F_meas
        ft._force_tracking_step(np.int64(k), xc, u, p, xc_next, y)
        out["F_meas"][k], out["F"][k], out["V"][k], out["sat"][k] = F_meas, F_true, y[0], y[1]
        out["integ"][k] = xc_next[0]
        x = A @ x + B * y[0]
        xc, xc_next = xc_next, xc
    out["x_plant"], out["x_ctrl"], out["states"] = x, xc, states
    return out


def pid_reference(p, F_set, F_meas, x0, anti_windup=True):
    """Plain per-tick reference of the force-tracking law (module docstring of
    tracking/force_tracking.py), inputs given (open loop). Returns (V, sat, integ).

    Clamping written as "the integral may move towards the limit only up to the headroom":
    a step up ends at min(trial, max(I_prev, headroom)), a step down at
    max(trial, min(I_prev, floor))."""
    c_v = 1.0 / p.inv_c_v
    I, D, y_prev = x0
    V, S, Ik = [], [], []
    for r, ym in zip(F_set, F_meas):
        e = r - ym
        D = p.d_pole * D - p.d_gain * (ym - y_prev)
        y_prev = ym
        rest = (r - p.F0) / c_v + p.Kp * e + D
        headroom, floor = p.V_max - rest, p.V_min - rest
        trial = I + p.Ki_dt * e
        if not anti_windup or p.Ki_dt * e == 0.0:
            I = trial
        elif p.Ki_dt * e > 0.0:
            I = min(trial, max(I, headroom))
        else:
            I = max(trial, min(I, floor))
        v = rest + I
        S.append(1.0 if I >= headroom else (-1.0 if I <= floor else 0.0))
        V.append(p.V_max if S[-1] > 0 else (p.V_min if S[-1] < 0 else v))
        Ik.append(I)
    return np.array(V), np.array(S), np.array(Ik)


def rise_time(y, final, dt):
    """10-90 % rise time [s] of a step response y (samples dt apart), linear interpolation."""
    def first(level):
        i = int(np.argmax(y >= level))
        return (i - 1 + (level - y[i - 1]) / (y[i] - y[i - 1])) * dt
    return first(0.9 * final) - first(0.1 * final)


def first_harmonic(x, n_period, periods=10):
    """Complex amplitude c of the first harmonic of x over its last whole periods (n_period
    samples each), x ~ Re(c exp(j 2 pi k / n_period)), k the absolute sample index (the DFT
    over whole periods removes the mean exactly)."""
    n = periods * n_period
    k = np.arange(len(x))[-n:]  # absolute sample index: the phase refers to k = 0
    return 2.0 / n * np.sum(x[-n:] * np.exp(-2j * np.pi * k / n_period))


@pytest.fixture(scope="module")
def cfg():
    return load()


@pytest.fixture(scope="module", params=ft.SENSORS)
def design(request, cfg):
    return ft.design_force_tracking(cfg, request.param)


# --- RT1 amplitude filter (Eq. 4) ---------------------------------------------------------------

def test_rt1_step_response_is_exact(cfg):
    # input step of u_rel = -2/pi * U at t = 0 (sign irrelevant: |u_rel|): the ZOH recursion is
    # exact, u0(t_{k+1}) = U (1 - exp(-t_{k+1}/T1)) to round-off (k eps ~ 1e-13 after 5 T1)
    U, T1, dt = 3e-6, cfg.tracking.T1_s, cfg.dt_s
    n = int(5 * T1 / dt)
    p = build_rt1(cfg)
    X, Y = run_open(_rt1_step, p, np.zeros(1), np.full((n, 1), -2 / math.pi * U), 1)
    t_next = (np.arange(n) + 1) * dt
    assert_rel(Y[:, 0], U * (1 - np.exp(-t_next / T1)), "RT1 step response", scale=U)
    assert_rel(X[1:, 0], Y[:, 0], "RT1 output = state at t_{k+1}", rtol=0.0, scale=U)


def test_rt1_settles_to_the_sine_amplitude(cfg):
    # u_rel = A sin(2 pi f t), f = 200 Hz: N = 105 samples per period (21 kHz). In periodic
    # steady state the mean of u0 over whole periods equals the mean of (pi/2)|u_rel,k| (unit DC
    # gain: summing u0_{k+1} = a u0_k + b|u_k| over a period gives (1-a) sum u0 = b sum |u|), and
    # for odd N sum_k |sin(2 pi k/N)| = cot(pi/(2N)), so mean u0 = A (pi/2) cot(pi/(2N)) / N
    # = A (1 - pi^2/(12 N^2) + ...) = A (1 - 7.5e-5). After 30 T1 the transient is e^-30.
    A, f, T1, dt = 20e-6, 200.0, cfg.tracking.T1_s, cfg.dt_s
    N = round(1 / (f * dt))
    assert N * f * dt == pytest.approx(1.0, abs=1e-12) and N % 2 == 1
    n = N * math.ceil(30 * T1 / (N * dt))
    k = np.arange(n)
    U = (A * np.sin(2 * np.pi * f * k * dt))[:, None]
    _, Y = run_open(_rt1_step, build_rt1(cfg), np.zeros(1), U, 1)
    last = Y[-10 * N:, 0]
    mean = last.mean()
    assert abs(mean - A) <= 0.01 * A, f"issue check: mean u0 {mean:.6e} vs A = {A:g} m"
    exact = A * (math.pi / 2) / (N * math.tan(math.pi / (2 * N)))
    assert mean == pytest.approx(exact, rel=1e-9)
    # the ripple: first harmonic of (pi/2)|sin| at 2f has amplitude 2/3 A, the first-order
    # filter attenuates it by 1/|1 + j 2 pi 2f T1| (~1/50); higher harmonics (4f: 2/15 A, /100)
    # and the sampling of the ripple's crest change the peak-to-peak by < 3 %: tolerance 5 %.
    # This is why the 1 % criterion is on the mean: the ripple alone is ~ +-1.3 %.
    ripple = last.max() - last.min()
    expect = 2 * (2 / 3) * A / abs(1 + 2j * np.pi * 2 * f * T1)
    assert ripple == pytest.approx(expect, rel=0.05)


def test_rt1_kernel_matches_reference(cfg):
    rng = np.random.default_rng(1)
    n = 3000
    u = rng.normal(scale=1e-5, size=n) + 5e-6 * np.sin(np.arange(n) * 0.3)
    u0_init = 4e-6
    p = build_rt1(cfg)
    _, Y = run_open(_rt1_step, p, np.array([u0_init]), u[:, None], 1)
    a = math.exp(-cfg.dt_s / cfg.tracking.T1_s)
    b = (1 - a) * math.pi / 2
    ref, _ = ss.lfilter([b], [1.0, -a], np.abs(u), zi=[a * u0_init])
    assert_rel(Y[:, 0], ref, "RT1 vs lfilter")


def test_rt1_wrapper_checks_shapes(cfg):
    p = build_rt1(cfg)
    x, xn, y = np.zeros(1), np.zeros(1), np.zeros(1)
    rt1_step(0, x, np.array([1e-5]), p, xn, y)
    assert y[0] == pytest.approx(p.b * 1e-5, rel=1e-15)
    assert RT1_SLOTS == ("u0",) and LAWS_SLOTS == RT1_SLOTS
    with pytest.raises(ValueError, match="state must have shape"):
        rt1_step(0, np.zeros(2), np.zeros(1), p, xn, y)
    with pytest.raises(ValueError, match="u_rel"):
        rt1_step(0, x, np.zeros(2), p, xn, y)


# --- control laws (SPEC 4) ----------------------------------------------------------------------

def law_once(cfg, law, u_rel=0.0, v_rel=0.0, u0=0.0):
    p = build_laws(cfg, law)
    x_next, y = np.empty(1), np.empty(2)
    laws_step(0, np.array([u0]), np.array([u_rel, v_rel]), p, x_next, y)
    return y[0], y[1], p


@pytest.mark.parametrize("F_passive, expect", [(40.0, 40.0), (250.0, 250.0), (10.0, 40.0), (900.0, 600.0)])
def test_passive_law(F_passive, expect):
    cfg = load(sets=[f"tracking.F_passive_N={F_passive}"])
    F, u0, _ = law_once(cfg, "passive", u_rel=1e-5, v_rel=0.3)
    assert F == expect  # a constant (or one of the limits), exactly
    assert u0 > 0.0     # the RT1 state runs whatever the law (logged)


@pytest.mark.parametrize("F_target, expect", [(100.0, 100.0), (599.0, 599.0), (25.0, 40.0), (2500.0, 600.0)])
def test_hysteresis_law(cfg, F_target, expect):
    # F* = K_f u0 (Eq. 3) with u0 the RT1 value at t_{k+1}: with u_rel = 0 it is a u0_k, so the
    # state is chosen to make K_f u0_{k+1} = F_target; then saturation to [40, 600] N
    p = build_laws(cfg, "hysteresis")
    u0_k = F_target / (cfg.tracking.K_f * p.rt1.a)
    F, u0, _ = law_once(cfg, "hysteresis", u0=u0_k)
    assert u0 == pytest.approx(F_target / cfg.tracking.K_f, rel=1e-15)
    assert F == pytest.approx(expect, rel=1e-14)


def test_hysteresis_law_uses_the_newest_sample(cfg):
    # u0_{k+1} = a u0_k + (1 - a)(pi/2)|u_rel,k|: a 10 um sample lifts u0 within the same tick
    p = build_laws(cfg, "hysteresis")
    F, u0, _ = law_once(cfg, "hysteresis", u_rel=-10e-6, u0=8e-6)
    expect_u0 = p.rt1.a * 8e-6 + (1 - p.rt1.a) * math.pi / 2 * 10e-6
    assert u0 == pytest.approx(expect_u0, rel=1e-13)
    assert F == pytest.approx(cfg.tracking.K_f * expect_u0, rel=1e-13)


@pytest.mark.parametrize("v_rel, expect", [
    (0.010, 600.0), (-0.010, 600.0),            # |v| = eps: the bang-bang branch (>=)
    (0.25, 600.0), (-3.0, 600.0),               # well outside the boundary layer
    (0.005, 300.0), (-0.005, 300.0),            # eps/2: F_max |v|/eps, both signs
    (0.001, 60.0), (-0.001, 60.0),              # above F_min still linear
    (0.0005, 40.0), (0.0, 40.0), (-0.0002, 40.0),  # F_max |v|/eps < F_min: F_min
])
def test_lyapunov_law(cfg, v_rel, expect):
    F, _, _ = law_once(cfg, "lyapunov", u_rel=1e-5, v_rel=v_rel)
    assert F == pytest.approx(expect, rel=1e-14)


def test_lyapunov_boundary_layer_is_continuous(cfg):
    eps = cfg.tracking.eps_m_s
    below, _, _ = law_once(cfg, "lyapunov", v_rel=eps * (1 - 1e-12))
    at, _, _ = law_once(cfg, "lyapunov", v_rel=eps)
    assert at == 600.0 and below == pytest.approx(600.0, rel=2e-12)


def test_laws_respect_configured_limits():
    cfg = load(sets=["tracking.F_min_N=100", "tracking.F_max_N=400", "tracking.eps_m_s=0.02",
                     "plant.screws.adaptive.F_N=200"])
    assert law_once(cfg, "lyapunov", v_rel=0.03)[0] == 400.0
    assert law_once(cfg, "lyapunov", v_rel=0.01)[0] == pytest.approx(200.0, rel=1e-14)  # 400 * 0.5
    assert law_once(cfg, "lyapunov", v_rel=0.004)[0] == 100.0                             # 80 -> F_min
    assert law_once(cfg, "passive")[0] == 100.0                                           # 40 -> F_min
    assert law_once(cfg, "hysteresis", u0=1.0)[0] == 400.0


def laws_reference(cfg, law, u_rel, v_rel, u0_init):
    """Vectorised reference: RT1 by lfilter, then the law's formula and sat (SPEC 4)."""
    t = cfg.tracking
    a = math.exp(-cfg.dt_s / t.T1_s)
    u0, _ = ss.lfilter([(1 - a) * math.pi / 2], [1.0, -a], np.abs(u_rel), zi=[a * u0_init])
    if law == "passive":
        F = np.full_like(u_rel, t.F_passive_N)
    elif law == "hysteresis":
        F = t.K_f * u0
    else:
        av = np.abs(v_rel)
        F = np.where(av >= t.eps_m_s, t.F_max_N, np.maximum(t.F_max_N * av / t.eps_m_s, t.F_min_N))
    return np.clip(F, t.F_min_N, t.F_max_N), u0


@pytest.mark.parametrize("law", list(LAW_CODES))
def test_laws_kernel_matches_reference(cfg, law):
    rng = np.random.default_rng(7)
    n = 4000
    k = np.arange(n)
    # u_rel: rest, then 40 um and 10 um sines (RT1 time constant 420 ticks), so K_f u0 spans
    # below, above and inside [40, 600] N; v_rel crosses the boundary layer in both directions
    # and hits |v| = eps exactly
    amp = np.select([k < 1500, k < 2800], [0.0, 40e-6], 10e-6)
    u_rel = amp * np.sin(2 * np.pi * k / 105) + rng.normal(scale=1e-8, size=n)
    v_rel = 0.03 * np.sin(2 * np.pi * k / 317) + rng.normal(scale=1e-3, size=n)
    v_rel[::50] = cfg.tracking.eps_m_s * np.sign(v_rel[::50])
    p = build_laws(cfg, law)
    assert p.law == LAW_CODES[law]
    X, Y = run_open(_laws_step, p, np.array([2e-6]), np.column_stack([u_rel, v_rel]), 2)
    F_ref, u0_ref = laws_reference(cfg, law, u_rel, v_rel, 2e-6)
    assert_rel(Y[:, 1], u0_ref, f"{law}: u0")
    assert_rel(X[1:, 0], u0_ref, f"{law}: RT1 state")
    assert_rel(Y[:, 0], F_ref, f"{law}: F_set")
    if law != "passive":  # the test spans both limits and the inside
        assert np.any(Y[:, 0] == cfg.tracking.F_min_N) and np.any(Y[:, 0] == cfg.tracking.F_max_N)
        assert np.any((Y[:, 0] > cfg.tracking.F_min_N) & (Y[:, 0] < cfg.tracking.F_max_N))


def test_law_names_and_wrapper(cfg):
    assert LAW_CODES == {"passive": 0, "hysteresis": 1, "lyapunov": 2}
    assert build_laws(load(sets=["tracking.law=lyapunov"])).law == 2
    with pytest.raises(ValueError, match="tracking.law"):
        build_laws(cfg, "skyhook")
    with pytest.raises(ValueError, match="v_rel"):
        laws_step(0, np.zeros(1), np.zeros(1), build_laws(cfg), np.zeros(1), np.zeros(2))


# --- force tracking: design (SPEC 3) ------------------------------------------------------------

def test_design_meets_the_loop_shape(cfg, design):
    t = cfg.tracking
    # crossover placed exactly (the gains solve |L(z_c)| = 1 in closed form)
    assert design.crossover_hz == pytest.approx(t.pid_bandwidth_hz, rel=1e-9)
    # the default actuator model lags only ~21 deg (strain) / ~5 deg (cell) at 300 Hz, so no PI
    # reaches 60 deg: the rule gives the pure integrator (largest Ki with crossover and PM >= 60)
    assert design.Kp == 0.0 and design.Ki > 0.0
    assert design.phase_margin_deg >= t.pid_phase_margin_deg
    assert design.phase_margin_min_deg == pytest.approx(design.phase_margin_deg, rel=1e-12)
    assert design.gain_margin_db > 6.0 and design.max_pole_abs < 1.0
    assert np.all(np.abs(design.closed_loop.poles()) < 1.0)
    # the margins agree with python-control's own (independent: polynomial/FRD method)
    gm, pm, _, _, wgc, _ = control.stability_margins(design.loop)
    assert design.phase_margin_deg == pytest.approx(pm, rel=1e-9)
    assert 2 * math.pi * design.crossover_hz == pytest.approx(wgc, rel=1e-9)
    assert design.gain_margin_db == pytest.approx(20 * math.log10(gm), rel=1e-6)
    print(f"\n{design.sensor}: {design.summary()}")


def test_design_reaches_the_phase_margin_where_a_pi_can():
    # at 1 kHz the strain-gauge chain lags ~60 deg: a PI (Kp > 0) gives exactly 60 deg
    cfg = load(sets=["tracking.pid_bandwidth_hz=1000"])
    d = ft.design_force_tracking(cfg, "strain")
    assert d.Kp > 0.0 and d.Ki > 0.0
    assert d.crossover_hz == pytest.approx(1000.0, rel=1e-9)
    assert d.phase_margin_deg == pytest.approx(60.0, abs=1e-7)


def test_unstable_gains_are_refused_with_a_clear_error():
    cfg = load(sets=["tracking.pid_bandwidth_hz=8000"])
    for sensor in ft.SENSORS:
        with pytest.raises(ValueError) as exc:
            ft.design_force_tracking(cfg, sensor)
        msg = str(exc.value)
        for part in ("Unstable PID gains", "Kp =", "Ki =", "closed-loop pole z =", "|z| =",
                     "tracking.pid_bandwidth_hz", f"sensors.{sensor}_bandwidth_hz"):
            assert part in msg, f"{part!r} missing from: {msg}"
    with pytest.raises(ValueError, match="Unstable PID gains"):
        ft.build_force_tracking(load(sets=["tracking.pid_bandwidth_hz=8000", "tracking.law=lyapunov"]))
    with pytest.raises(ValueError, match="Nyquist"):
        ft.design_force_tracking(load(sets=["tracking.pid_bandwidth_hz=11000"]), "cell")
    with pytest.raises(ValueError, match="sensor"):
        ft.design_force_tracking(load(), "laser")


def test_resonance_crossing_warns():
    # 1 kHz with the cell: stable, but the stack resonance lifts |L| above 1 near 7 kHz
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        d = ft.design_force_tracking(load(sets=["tracking.pid_bandwidth_hz=1000"]), "cell")
    assert d.max_pole_abs < 1.0 and d.phase_margin_min_deg < 0.0
    assert any("tracking.pid_phase_margin_deg" in str(x.message) for x in w)


def test_actuator_model_gains(cfg):
    # DC gain c_v on both outputs; the stack resonance at sqrt((k_stack + k_screw)/m)
    a = cfg.actuator
    for sensor in ft.SENSORS:
        G = ft.actuator_model(cfg, sensor)
        np.testing.assert_allclose(G.dcgain()[:, 0], [a.c_v, a.c_v], rtol=1e-12)
        Gd = ft.discrete_actuator_model(cfg, sensor)
        np.testing.assert_allclose(Gd.dcgain()[:, 0], [a.c_v, a.c_v], rtol=1e-10)
    wm = math.sqrt((a.k_stack + a.k_screw) / a.moving_mass_kg)
    poles = ft.actuator_model(cfg, "cell").poles()
    mech = poles[np.argmin(np.abs(np.abs(poles) - wm))]
    assert abs(mech) == pytest.approx(wm, rel=1e-12)
    assert -mech.real / abs(mech) == pytest.approx(a.zeta_stack, rel=1e-12)


# --- force tracking: closed-loop behaviour --------------------------------------------------------

def test_step_zero_error_and_rise_time(cfg, design):
    """(a) 100 N step on the linear discrete loop (python-control, no saturation).

    Zero steady-state error: the integrator makes the DC gain of F_meas/F* and F/F* exactly 1.
    Rise time vs bandwidth: the PID-only loop L/(1+L) is close to a first-order lag (pure
    integrator on a plant flat to ~1 kHz), whose 10-90 % rise time is t_r = ln 9 / (2 pi f_bw);
    checked within 10 % (the sensor pole and the ZOH make it slightly non-first-order: observed
    -1.7 % strain, +1.5 % cell). With the feedforward the response is faster still (t_r no
    larger than the PID-only one) and, where the -3 dB bandwidth is finite (strain), t_r f_bw
    lies in [0.2, 0.45], the band of 1st/2nd-order responses with damping 0.3..1 (0.26-0.35)
    widened for the feedforward's zero (observed 0.253, 23 % overshoot).
    """
    dt = cfg.dt_s
    n = 3000
    tt = np.arange(n) * dt
    r = control.forced_response(design.closed_loop, T=tt, U=np.full(n, 100.0))
    F_meas, F, V = r.outputs
    dc = design.closed_loop.dcgain()[:, 0]
    np.testing.assert_allclose(dc[:2], [1.0, 1.0], rtol=1e-9)
    assert abs(F_meas[-1] - 100.0) < 1e-9 and abs(F[-1] - 100.0) < 1e-9
    assert V[-1] == pytest.approx(100.0 / cfg.actuator.c_v, rel=1e-9)
    T_fb = control.feedback(design.loop, 1)
    y_fb = control.forced_response(T_fb, T=tt, U=np.full(n, 100.0)).outputs
    assert abs(y_fb[-1] - 100.0) < 1e-9
    tr_fb = rise_time(y_fb, 100.0, dt)
    assert tr_fb * design.bandwidth_fb_hz == pytest.approx(LN9_2PI, rel=0.10)
    tr = rise_time(F_meas, 100.0, dt)
    assert tr <= tr_fb
    if math.isfinite(design.bandwidth_hz):
        assert 0.2 <= tr * design.bandwidth_hz <= 0.45
    print(f"\n{design.sensor}: t_r PID only {tr_fb * 1e3:.3f} ms "
          f"(x f_bw {tr_fb * design.bandwidth_fb_hz:.3f}), "
          f"FF+PID {tr * 1e3:.3f} ms, overshoot F_meas {F_meas.max() - 100:.1f} N, F {F.max() - 100:.1f} N")


def test_sine_setpoint_tracked_as_the_frequency_response(cfg, design):
    """(b) F* = 300 + 100 sin(2 pi 200 t) N through the njit kernel in closed loop with the
    NumPy actuator model: the first harmonic of F_meas (and of the true F) equals
    100 N x T(exp(j w dt)) of the designed closed loop. Issue tolerance 1 %; asserted 1e-9,
    since both are the same discrete linear system once the transient (|z| <= 0.92, 2000
    ticks: < 1e-70) is gone, and the DFT over whole periods (105 samples) is exact."""
    dt, f = cfg.dt_s, 200.0
    N = round(1 / (f * dt))
    n = 2000 + 10 * N
    k = np.arange(n)
    F_set = 300.0 + 100.0 * np.sin(2 * np.pi * k / N)
    out = run_loop(design, design.params, F_set)
    assert np.all(out["sat"] == 0.0)
    w = 2 * np.pi * f
    for i, name in ((0, "F_meas"), (1, "F")):
        T = ft._freq(design.closed_loop, w, dt, out=i)[0]
        h = first_harmonic(out[name], N) / (100.0 * np.exp(-0.5j * np.pi))  # sin = cos(. - pi/2)
        assert abs(h - T) <= 1e-9 * abs(T), f"{name}: {h} vs {T}"
        assert abs(abs(h) - abs(T)) <= 0.01 * abs(T)  # the 1 % on gain
        print(f"\n{design.sensor} {name}/F* at 200 Hz: gain {abs(h):.4f}, "
              f"phase {np.degrees(np.angle(h)):.2f} deg")


@pytest.mark.parametrize("gains", ["designed", "pid"])
def test_kernel_closed_loop_equals_python_control(cfg, design, gains):
    """(c) njit kernel + NumPy plant vs python-control's simulation of the same discrete closed
    loop (interconnect of the ZOH actuator model and ``controller_model``), 1e-9 relative, on
    a short run without saturation. 'pid' adds proportional and filtered derivative action."""
    p = design.params if gains == "designed" else ft.force_tracking_params(cfg, Kp=0.02, Ki=400.0, Kd=5e-7)
    cl = ft.closed_loop_model(cfg, design.sensor, p)
    assert np.all(np.abs(cl.poles()) < 1.0)
    n = 600
    k = np.arange(n)
    F_set = 200.0 + 60.0 * (k >= 40) + 30.0 * np.sin(2 * np.pi * 500.0 * k * cfg.dt_s) * (k >= 300)
    out = run_loop(design, p, F_set)
    assert np.all(out["sat"] == 0.0)
    F0 = p.F0
    ref = control.forced_response(cl, T=k * cfg.dt_s, U=F_set - F0).outputs
    assert_rel(out["F_meas"] - F0, ref[0], f"{gains}: F_meas", rtol=CL_RTOL)
    assert_rel(out["F"] - F0, ref[1], f"{gains}: F", rtol=CL_RTOL)
    assert_rel(out["V"], ref[2], f"{gains}: V", rtol=CL_RTOL)


def test_kernel_matches_reference_with_saturation(cfg):
    # open loop: arbitrary setpoints and measurements driving the output into both limits
    rng = np.random.default_rng(3)
    n = 3000
    k = np.arange(n)
    F_set = np.clip(320 + 300 * np.sin(2 * np.pi * k / 700) + rng.normal(scale=20, size=n), 40, 600)
    F_meas = F_set + 80 * np.sin(2 * np.pi * k / 330) + rng.normal(scale=5, size=n)
    for p in (ft.force_tracking_params(cfg, Kp=0.05, Ki=400.0, Kd=2e-6),
              ft.build_force_tracking(cfg, "strain")):
        x0 = np.array([3.0, 0.5, 250.0])
        X, Y = run_open(ft._force_tracking_step, p, x0, np.column_stack([F_set, F_meas]), 2)
        V, S, I = pid_reference(p, F_set, F_meas, x0)
        assert np.any(S > 0) and np.any(S < 0) and np.any(S == 0)
        assert_rel(Y[:, 0], V, "V_cmd", scale=p.V_max - p.V_min)
        assert np.array_equal(Y[:, 1], S)
        assert_rel(X[1:, 0], I, "integrator", scale=np.max(np.abs(I)))
        assert np.array_equal(X[1:, 2], F_meas)


@pytest.mark.parametrize("side", ["upper", "lower"])
def test_anti_windup(cfg, side):
    """(d) Feedforward mismatch that no voltage can correct: the true force at 0 V is 150 N
    below (upper) / 60 N above (lower) the configured F0, and F* asks for 500 N (upper: needs
    163.5 V > 150 V) / 40 N (lower: needs -16 V < 0 V) for 2000 ticks, then a reachable 300 N.

    Criteria: (1) once saturated the integrator is frozen (changes by exactly 0 while the error
    keeps its sign) and |I| stays below V_max - V_min; without anti-windup (reference with the
    clamping disabled) it winds up to > 10 x that. (2) From the tick of the setpoint change the
    output is inside the limits and the loop continues exactly as the linear closed loop
    (python-control from the same state, 1e-9): no memory of the saturation is left. The
    windup reference instead stays saturated for > 100 ticks (observed 586 lower, 670 upper).
    """
    d = ft.design_force_tracking(cfg, "strain")
    p = d.params
    off, F_hold = (-150.0, 500.0) if side == "upper" else (60.0, 40.0)
    k1, n = 2000, 3000
    F_set = np.where(np.arange(n) < k1, F_hold, 300.0)
    out = run_loop(d, p, F_set, F0_true=p.F0 + off)
    sat, I = out["sat"], out["integ"]
    s_val = 1.0 if side == "upper" else -1.0
    first = int(np.argmax(sat == s_val))
    assert first < 50 and np.all(sat[first:k1] == s_val)
    assert np.all(I[first + 1:k1] == I[first])          # frozen, exactly
    assert np.max(np.abs(I)) < p.V_max - p.V_min
    # the same run without anti-windup winds up
    V_w, S_w, I_w = _windup_run(d, p, F_set, p.F0 + off)
    assert np.max(np.abs(I_w[:k1])) > 10 * (p.V_max - p.V_min)
    inside = np.nonzero(S_w[k1:] == 0.0)[0]
    stuck = int(inside[0]) if inside.size else n - k1
    assert stuck > 100
    # (2) recovery
    assert np.all(sat[k1:] == 0.0)
    ref = _mismatch_loop_response(cfg, d, p, F_set[k1:], off, out["states"][k1], I[k1 - 1])
    assert_rel(out["F_meas"][k1:] - (p.F0 + off), ref[0], "recovery F_meas", rtol=CL_RTOL)
    assert_rel(out["V"][k1:], ref[2] + off * p.inv_c_v, "recovery V", rtol=CL_RTOL)
    print(f"\n{side}: integrator frozen at {I[first]:.2f} V from tick {first}; without anti-windup "
          f"|I| reaches {np.max(np.abs(I_w[:k1])):.0f} V and the output stays saturated {stuck} "
          f"ticks after the setpoint change (with it: 0)")


def _mismatch_loop_response(cfg, d, p, F_set, off, x_plant, integ):
    """python-control's simulation of the linear loop with the F0 mismatch, from a given state.

    In deviations from the true F0' = F0 + off the feedforward (F* - F0)/c_v is
    (F* - F0')/c_v + off/c_v: a constant voltage offset entering the actuator next to the
    controller's output. The actuator model gets it as a second input (same B); states are
    ordered actuator, then controller (Kd = 0: the integrator only)."""
    G = d.plant
    G2 = control.ss(G.A, np.hstack([G.B, G.B]), G.C, np.zeros((2, 2)), cfg.dt_s,
                    inputs=["V", "V_off"], outputs=["F", "F_meas"], name="actuator2")
    cl = control.interconnect([G2, ft.controller_model(p, cfg.dt_s)], inputs=["F_set", "V_off"],
                              outputs=["F_meas", "F", "V"])
    assert cl.nstates == G.nstates + 1
    n = len(F_set)
    U = np.vstack([F_set - (p.F0 + off), np.full(n, off * p.inv_c_v)])
    return control.forced_response(cl, T=np.arange(n) * cfg.dt_s, U=U,
                                   X0=np.concatenate([x_plant, [integ]])).outputs


def _windup_run(d, p, F_set, F0_true):
    """The closed loop with the reference PID and its clamping disabled (per tick)."""
    A, B, C = np.asarray(d.plant.A), np.asarray(d.plant.B)[:, 0], np.asarray(d.plant.C)
    x = np.zeros(A.shape[0])
    xc = ft.initial_state(F0_true)
    V, S, I = [], [], []
    for r in F_set:
        ym = F0_true + C[1] @ x
        v, s, i = pid_reference(p, [r], [ym], xc, anti_windup=False)
        xc = np.array([i[0], 0.0, ym])  # Kd = 0 in the design: D stays 0
        x = A @ x + B * v[0]
        V.append(v[0]), S.append(s[0]), I.append(i[0])
    return np.array(V), np.array(S), np.array(I)


# --- run-time properties ------------------------------------------------------------------------

def test_kernels_are_cached_nogil_and_without_reference_counting(cfg):
    # _nrt=False: numba refuses at compile time anything that would allocate; cache=True and
    # nogil=True as every run-time kernel (STYLE 1)
    rt1_step(0, np.zeros(1), np.zeros(1), build_rt1(cfg), np.zeros(1), np.zeros(1))
    laws_step(0, np.zeros(1), np.zeros(2), build_laws(cfg), np.zeros(1), np.zeros(2))
    ft.force_tracking_step(0, np.zeros(3), np.zeros(2), ft.force_tracking_params(cfg, 0.0, 1.0),
                           np.zeros(3), np.zeros(2))
    for f in (_rt1_step, _laws_step, ft._force_tracking_step):
        assert f.targetoptions.get("nogil") is True, f.__name__
        assert f.targetoptions.get("_nrt") is False, f.__name__
        assert type(f._cache).__name__ == "FunctionCache", f.__name__
        assert f.signatures, f"{f.__name__} was not compiled by the tests"


def test_force_tracking_wrapper_and_initial_state(cfg):
    p = ft.force_tracking_params(cfg, Kp=0.0, Ki=500.0)
    x = ft.initial_state(300.0)
    assert ft.FORCE_TRACKING_SLOTS == ("integ", "deriv", "F_meas_prev") and x.shape == (3,)
    xn, y = np.empty(3), np.empty(2)
    ft.force_tracking_step(0, x, np.array([300.0, 300.0]), p, xn, y)
    assert y[0] == pytest.approx((300.0 - 40.0) / 3.73, rel=1e-15) and y[1] == 0.0  # feedforward only
    with pytest.raises(ValueError, match="state must have shape"):
        ft.force_tracking_step(0, np.zeros(2), np.zeros(2), p, xn, y)
    with pytest.raises(ValueError, match="F_meas"):
        ft.force_tracking_step(0, x, np.zeros(3), p, xn, y)
    assert ft.SENSOR_OF_LAW == {"passive": "strain", "hysteresis": "strain", "lyapunov": "cell"}
