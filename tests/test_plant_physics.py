"""Physics checks of the plant (issue 2, checks 1-7): numbers against analytic solutions,
an independent full model, exact linear theory and the energy balance."""
import numpy as np
import pytest
import scipy.linalg as sla

from frictionrt.plant.contact import _jenkins_pair
from frictionrt.plant.energy import balance
from frictionrt.plant.impulse import MODES, accelerance_frf, fit_mode, hammer_force, impulse_test, identify
from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz, stuck_stiffness
from frictionrt.plant.modes import bare_beam_bending_hz
from frictionrt.plant.simulate import run
from frictionrt.rt.common.config import load, with_sets

# Euler-Bernoulli cantilever, L = 0.775 m, h = 8 mm, steel (issue 2, check 1)
ANALYTIC_BARE_HZ = np.array([11.13, 69.74, 195.28, 382.67, 632.58, 944.97])


def _series(model, Y, name):
    return Y[:, model.output_index()[name]]


def _pairs(model, Y, sym):
    idx = model.output_index()
    return Y[:, [idx[f"{sym}_{j}"] for j in range(model.n_pairs)]]


# --- check 1 -------------------------------------------------------------------------------

def test_bare_cantilever_matches_euler_bernoulli(full):
    # the analytic values are given to 4-5 significant digits (rounding <= 0.05 %); the
    # 10 mm cubic mesh converges far below that, so 0.1 % is the tolerance with margin
    f = bare_beam_bending_hz(full, "main")
    assert f.shape == (6,)
    np.testing.assert_allclose(f, ANALYTIC_BARE_HZ, rtol=1e-3)


# --- check 2 -------------------------------------------------------------------------------

def test_reduced_matches_full_stuck_frequencies_below_2khz(full, reduced):
    f_full = stuck_frequencies_hz(full)
    f_red = stuck_frequencies_hz(reduced)
    n = int(np.sum(f_full < 2000.0))
    assert n >= 8  # modes 1..8 of the assembly lie below 2 kHz
    err = np.abs(f_red[:n] - f_full[:n]) / f_full[:n]
    # Craig-Bampton only stiffens (Rayleigh-Ritz): reduced >= full up to the eigensolver's round-off,
    # |d lambda| <= c eps ||K|| (mass-normalised), i.e. df/f <= c eps lambda_max / (2 lambda_i) with
    # c = 64; the stiff contact puts lambda_max near (2 pi 1 MHz)^2, so mode 1 (9.8 Hz) is known to
    # ~1e-6 only (measured 8e-8 below the full model's on one machine); SPEC asks 0.5 %
    lam_max = np.max(np.linalg.eigvalsh(stuck_stiffness(full)))
    tol = 64 * np.finfo(float).eps * lam_max / (2 * (2 * np.pi * f_full[:n]) ** 2)
    assert np.all(f_red[:n] >= f_full[:n] * (1 - tol))
    assert err.max() < 5e-3, f"largest error {100 * err.max():.3f} %"


def test_reduced_transient_matches_full(cfg, full, reduced):
    """Hammer 20 N at F_N1 = 100 N (pairs closed, the adaptive pair slips), 50 ms.

    Compared: tip displacement, and tip acceleration in the band the models are built for
    (zero-phase 4th-order low-pass at 1.5 kHz; SPEC validates the reduction below 2 kHz).
    The raw acceleration differs by ~30 % whatever the cut-off: modes far above the 10.5 kHz
    Nyquist frequency (up to MHz in the full model) are not damped by the trapezoidal rule
    and ring near Nyquist after every zero-order-hold step; their sets differ between the two
    models (docs/plant.md, "Unresolved modes").
    """
    import scipy.signal as ss
    n = int(round(0.05 / cfg.dt_s))
    F = hammer_force(n, cfg.dt_s, 20.0, 0.5e-3)
    Y_f, _, _ = run(full, F, 100.0)
    Y_r, _, _ = run(reduced, F, 100.0)
    k_t = full.structure.k_t[-1]   # the last pair's stiffness [N/m] (its tributary area x k_t_area)
    slider = _pairs(full, Y_f, "g_t")[:, -1] - _pairs(full, Y_f, "f_t")[:, -1] / k_t
    assert np.ptp(slider) > 1e-7  # the contact is really active: the adaptive pair slips

    def rel_rms(a, b):
        return np.sqrt(np.mean((a - b) ** 2) / np.mean(a**2))

    sos = ss.butter(4, 1500.0, fs=1 / cfg.dt_s, output="sos")
    a_f = ss.sosfiltfilt(sos, _series(full, Y_f, "a_tip"))
    a_r = ss.sosfiltfilt(sos, _series(reduced, Y_r, "a_tip"))
    assert rel_rms(_series(full, Y_f, "w_tip"), _series(reduced, Y_r, "w_tip")) < 0.02
    assert rel_rms(a_f, a_r) < 0.02, f"band-limited tip acceleration differs by {100 * rel_rms(a_f, a_r):.2f} %"


# --- check 3 -------------------------------------------------------------------------------

def _jenkins_cycle_energy(u0, F_N, k_t, mu, n=20000):
    """Energy dissipated per cycle [J]: loop area of f_t over g_t = u0 sin, second cycle."""
    k_n = 1e9
    g_n = -F_N / k_n
    w = 0.0
    t = np.linspace(0.0, 2.0, 2 * n + 1)  # two periods; the first settles the slider
    g_t = u0 * np.sin(2 * np.pi * t)
    f = np.empty_like(t)
    for i, gt in enumerate(g_t):
        _, lt, w, _, _, _ = _jenkins_pair(g_n, gt, w, k_n, k_t, mu)
        f[i] = -lt
    sl = slice(n, 2 * n + 1)
    return np.trapezoid(f[sl], g_t[sl])


def test_jenkins_energy_per_cycle():
    k_t, mu, u0 = 8e8, 0.4, 1e-6
    for F_N in (100.0, 500.0, 900.0):
        F_c = mu * F_N
        expected = 4 * F_c * (u0 - F_c / k_t)
        # trapezoid of a piecewise-linear loop sampled at 20000 points per cycle: error ~1e-4
        assert _jenkins_cycle_energy(u0, F_N, k_t, mu) == pytest.approx(expected, rel=5e-3)


def test_jenkins_energy_peaks_at_hysteresis_optimal_force():
    k_t, mu, u0 = 8e8, 0.4, 1e-6
    F_opt = k_t * u0 / (2 * mu)  # 1000 N
    F_grid = np.linspace(0.5, 1.5, 41) * F_opt
    W = np.array([_jenkins_cycle_energy(u0, F, k_t, mu, n=4000) for F in F_grid])
    # grid spacing 2.5 % of F_opt: the discrete argmax lies within one spacing of F_opt
    assert abs(F_grid[np.argmax(W)] - F_opt) <= 0.026 * F_opt
    assert W.max() == pytest.approx(k_t * u0**2, rel=5e-3)


# --- check 4 -------------------------------------------------------------------------------

@pytest.mark.parametrize("peak, fn1", [(50.0, 100.0), (500.0, 40.0)])
def test_energy_balance_on_transient(cfg, reduced, peak, fn1):
    """W_exc + W_screw = dT + dV + E_fric + E_damp within 1 % of the input work.

    W_exc and E_fric are recomputed here from the logged outputs (force times displacement of
    the excitation point; mean tangential force times slider motion w = g_t - f_t / k_t), not
    taken from the kernel's accumulators; T and V come from the state (plant.energy).
    """
    m = reduced
    n = int(round(0.3 / cfg.dt_s))
    F = hammer_force(n, cfg.dt_s, peak, 0.5e-3)
    x0 = m.initial_state(fn1)
    Y, x, _ = run(m, F, fn1, x0=x0)
    w_exc = np.concatenate([[0.0], _series(m, Y, "w_exc")])
    w_exc[0] = reduced.params.out_rows[0] @ x0[m.state_slots()["q"]]
    W_exc = float(np.sum(F * np.diff(w_exc)))  # inputs are held over each step (ZOH)
    g_t, f_t = _pairs(m, Y, "g_t"), _pairs(m, Y, "f_t")
    k_t = m.structure.k_t    # per pair [N/m]
    w_sl = g_t - f_t / k_t
    sl = m.state_slots()
    g0 = x0[sl["g"]]
    w0 = x0[sl["w"]]
    f_t0 = k_t * (g0[1::2] - w0)
    f_all = np.vstack([f_t0, f_t])
    w_all = np.vstack([w0, w_sl])
    dE_fric = np.sum(0.5 * (f_all[1:] + f_all[:-1]) * np.diff(w_all, axis=0), axis=1)
    E_fric = float(dE_fric.sum())
    b = balance(m, x0, x)
    assert W_exc == pytest.approx(b["W_exc"], rel=1e-9)
    # per step, the trapezoid over the step equals the kernel's increment, except on steps
    # redone as fallback substeps (the kernel sums the trapezoid over h/4 pieces there)
    fb = _series(m, Y, "substep_fallbacks") > 0
    dE_k = np.diff(np.concatenate([[x0[sl["E_fric"]][0]], _series(m, Y, "E_fric")]))
    np.testing.assert_allclose(dE_fric[~fb], dE_k[~fb], rtol=1e-6, atol=1e-12 * abs(E_fric))
    residual = W_exc + b["W_screw"] - b["dT"] - b["dV"] - E_fric - b["E_damp"]
    assert E_fric > 0.1 * W_exc  # friction really dissipates in this transient
    assert abs(residual) < 0.01 * W_exc, f"residual {residual:.3e} J of {W_exc:.3e} J input"


# --- check 5 -------------------------------------------------------------------------------

@pytest.mark.parametrize("qs_sets, lo, hi, err_dt", [
    (["plant.quasi_static_hz=1e9", "plant.period_match=false"], 1.8, 2.2, 5e-4),
    (["plant.quasi_static_hz=1e9"], 2.1, 4.0, 1e-4),
    (["plant.quasi_static_hz=10500", "plant.quasi_static_theta=0", "plant.period_match=false"], 0.9, 1.3, 2e-3),
    ([], 1.0, 1.5, 1.5e-4)])
def test_step_size_convergence_on_stuck_case(qs_sets, lo, hi, err_dt):
    """dt, dt/2, dt/4 against dt/32 on a smooth case where no pair slips or opens. With every
    mode stepped by the plain trapezoid errors fall by 4 per halving: average acceleration is
    second order (measured 3.9e-4 of the rms at dt, orders 1.89, 1.99). Period-matched (docs/plant.md
    2.2) the modes' period error is gone: 5.2e-5 at dt, orders 2.3, 3.6. With the quasi-static
    modes stepped by implicit Euler (theta 0, above 10.5 kHz: the plant before issue 15's fix) they
    fall by 2: their static response to the step's mean load lags by h/2 (docs/plant.md 2.6;
    measured 1.1e-3 at dt, orders 1.12, 1.13). The default (period-matched, theta 0.9 above 3 kHz)
    leaves that lag at 0.05 h, now the leading error: measured 1.09e-4 at dt (plain trapezoid:
    4.1e-4), orders 1.24, 1.17."""
    errs = []
    ref = None
    for m_sub in (32, 1, 2, 4):
        cfg = load(sets=[f"plant.substeps={m_sub}", "plant.interface.mu=2.0"] + qs_sets)
        model = build_plant(cfg)
        n = int(round(0.02 / cfg.dt_s))
        F = hammer_force(n, cfg.dt_s, 1.0, 4e-3)  # smooth 4 ms pulse, 1 N: stays stuck
        Y, _, _ = run(model, F, 600.0)
        w = _series(model, Y, "w_tip")
        g_n = _pairs(model, Y, "g_n")
        assert np.array_equal(g_n[-1] < 0, preloaded_pairs(model, 600.0))  # no pair opened or closed
        if ref is None:
            ref = w
        else:
            errs.append(np.sqrt(np.mean((w - ref) ** 2)) / np.sqrt(np.mean(ref ** 2)))
    order = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all((order > lo) & (order < hi)), f"observed orders {order}"
    assert errs[0] < err_dt


# --- check 6 -------------------------------------------------------------------------------

def test_normal_contact_opens_and_closes_without_nan(cfg, reduced):
    m = reduced
    fn1, peak = cfg.tracking.F_min_N, 500.0
    n = int(round(0.3 / cfg.dt_s))
    Y, _, _ = run(m, hammer_force(n, cfg.dt_s, peak, 0.5e-3), fn1)
    assert np.all(np.isfinite(Y))
    g_n = _pairs(m, Y, "g_n")
    f_n = _pairs(m, Y, "f_n")
    closed = g_n < 0
    changes = np.abs(np.diff(closed.astype(int), axis=0)).sum(axis=0)
    # away from the screws (> 30 mm) the interface is open under preload or lightly closed: the
    # hammer closes and opens some of those pairs repeatedly (measured 20, 4, 28 events)
    far = [j for j in range(m.n_pairs) if min(abs(m.structure.x_pairs[j] - s.x_m) for s in cfg.plant.screws) > 0.03]
    assert sum(changes[j] >= 2 for j in far) >= 2, f"open/close events per pair {changes}"
    # penetration only as deep as the penalty law with the forces that act: f_n = k_n (-g_n),
    # and the contact forces stay within a dynamic factor 3 of screw + hammer forces
    k_n = m.structure.k_n    # per pair [N/m]
    np.testing.assert_allclose(f_n, np.maximum(0.0, -g_n) * k_n, rtol=1e-12, atol=1e-9)
    bound = 3 * (cfg.plant.screws[0].F_N + fn1 + peak) / k_n.min()
    assert -g_n.min() < bound


# --- check 7 -------------------------------------------------------------------------------

def test_passive_damper_identified_modes(reduced, capsys):
    res = impulse_test(reduced, 100.0)
    f, z = res.freq_hz, res.damping_ratio
    with capsys.disabled():
        print(f"\n[check 7] F_N1 = 100 N, hammer {reduced.cfg.impulse.peak_N} N: modes {MODES} "
              f"f = {np.round(f, 2)} Hz, zeta = {np.round(100 * z, 3)} %")
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(z))
    assert 215.0 <= f[1] <= 235.0  # mode 3: the paper's friction-affected peak near 230 Hz
    bare = reduced.cfg.plant.modal_damping
    assert z[1] > 3 * bare and z[2] > 3 * bare  # modes 3 and 4 clearly above the bare 0.1 %
    assert np.argmin(z) == 0  # mode 2 the least damped of modes 2-5


@pytest.mark.filterwarnings("ignore::UserWarning")  # sdypy-EMA clamps its band to the FFT bins
def test_identification_matches_linear_theory(cfg, reduced):
    """On a linear response (1 N hammer, mu = 2: nothing slips; at mu = 0.4 the default joint's
    lightly pressed points at the edges of the screws' pressure zones slip under a 10 N hammer and
    lower mode 5 by 0.5 %) the identified frequencies and
    damping ratios equal the eigenvalues of the linearised damped system the step integrates
    (every mode stepped, with the step's modal masses and damping, docs/plant.md 2.2), mapped
    exactly through the integrator (the trapezoid's exact pole map); sdypy-EMA's LSCF, an
    independent identification, agrees too."""
    m = build_plant(load(sets=["plant.quasi_static_hz=1e9", "plant.interface.mu=2.0"]))
    x0 = m.initial_state(100.0)
    closed = preloaded_pairs(m, 100.0)
    p = m.params
    K = stuck_stiffness(m, closed)
    A = np.block([[np.zeros((m.n, m.n)), np.eye(m.n)], [-K / p.m_step[:, None], -np.diag(p.c_step / p.m_step)]])
    lam = sla.eigvals(A)
    lam = lam[lam.imag > 1.0]
    lam = lam[np.argsort(np.abs(lam))]
    # the trapezoidal rule maps each pole exactly by z = (1 + lam h/2) / (1 - lam h/2); what an
    # FRF of the sampled response shows is s = ln(z) / h (period elongation (omega h)^2 / 12)
    h = cfg.dt_s
    s_d = np.log((1 + lam * h / 2) / (1 - lam * h / 2)) / h
    f_th = np.abs(s_d) / (2 * np.pi)
    z_th = -s_d.real / np.abs(s_d)
    sel = [int(np.argmin(np.abs(f_th - f0))) for f0 in stuck_frequencies_hz(m, closed)[[k - 1 for k in MODES]]]
    n = int(round(2.0 / cfg.dt_s))
    F = hammer_force(n, cfg.dt_s, 1.0, 0.5e-3)
    Y, _, _ = run(m, F, 100.0, x0=x0)
    tau = 0.5
    freq, H = accelerance_frf(F, _series(m, Y, "a_frf"), cfg.dt_s, tau)
    fn, zeta = identify(freq, H, f_th[sel], tau)
    # frequency: the fit resolves far below the 0.5 Hz bin; damping ~0.09 % to within 10 %
    np.testing.assert_allclose(fn, f_th[sel], rtol=2e-4)
    np.testing.assert_allclose(zeta, z_th[sel], rtol=0.10)
    # cross-check with sdypy-EMA on the same FRF for mode 3 (windowed pole, before correction)
    from sdypy import EMA
    f0 = f_th[sel][1]
    band = (freq > 0.92 * f0) & (freq < 1.08 * f0)
    ema = EMA.Model(frf=H[band][None, :], freq=freq[band], lower=0.92 * f0, upper=1.08 * f0,
                    pol_order_high=8, frf_form="accelerance")
    ema.get_poles(method="lscf", show_progress=False)
    ema.select_closest_poles([f0], f_window=0.05 * f0)
    f_fit, xi_fit = fit_mode(freq, H, 0.92 * f0, 1.08 * f0)
    assert float(np.asarray(ema.nat_freq)[0]) == pytest.approx(f_fit, rel=1e-3)
    # LSCF's damping of a 0.2 % mode on the windowed FRF: 5.9 % from the fit on an AMD EPYC machine
    # with the same package versions (the fit itself is checked against theory above, to 10 %)
    assert float(np.asarray(ema.nat_xi)[0]) == pytest.approx(xi_fit, rel=0.08)


def test_contact_solve_falls_back_to_fine_substeps():
    """A step whose contact Newton stalls is redone on fine substeps; the run completes and the
    energy balance still closes. Without interface damping (F_N1 = 40 N, 1000 N hammer) and with
    Newton limited to 7 iterations, the steps in which several pairs change state stall (53-63 of
    6300 on an AMD EPYC, with the design's BLAS on one thread or two), redone on 16 substeps; with
    the default 40 iterations a stall is a rare event, so the mechanism is tested where it is
    frequent. Not 6 iterations (the test before): there a fine substep's solve can stall too, and
    the run then stalls in every later step (5859 of 6300 with the design's BLAS on one thread,
    none on two): which one happens was decided by the design's last bits."""
    # the quasi-static modes as before issue 15's lag-free step (tests/test_kernels_reference.py
    # UNDAMPED_QS: with the defaults the capped solves stall in runs and the fine substeps fail too)
    # and the joint as before issue 31 (20 mm pitch, the earlier stiffness per area, the plain trapezoid):
    # on the default joint the capped solves stall in runs that the fine substeps do not end either
    cfg = load(sets=["plant.interface.tau_s=0", "plant.newton_max_iter=7", "plant.fallback_split=16",
                     "plant.quasi_static_theta=0", "plant.quasi_static_hz=10500", "plant.interface.pitch_m=0.02",
                     "plant.interface.end_refinement=1",
                     "plant.element_length_m=0.01", "plant.interface.k_n_area=2.125e12",
                     "plant.interface.k_t_area=1.75e12", "plant.period_match=false"])
    m = build_plant(cfg)
    n = int(round(0.3 / cfg.dt_s))
    x0 = m.initial_state(40.0)
    Y, x, _ = run(m, hammer_force(n, cfg.dt_s, 1000.0, 0.5e-3), 40.0, x0=x0)
    assert Y[:, m.output_index()["substep_fallbacks"]].sum() >= 20
    b = balance(m, x0, x)
    assert abs(b["residual"]) < 1e-6 * b["W_exc"]


def test_quasi_static_modes_add_little_damping_to_the_linear_modes():
    """The quasi-static modes' lag (1 - theta) h/2 damps the linear modes (docs/plant.md 2.6): on
    the 10 N hammer at F_N1 = 100 N (nothing slips) modes 2..5 identify with more damping than
    the model with every mode stepped. Implicit Euler (theta 0) above 10.5 kHz, the plant before
    issue 15's fix: +0.013, +0.120, +0.192, +0.145 % (measured). The default (theta 0.9 above
    3 kHz) must stay within 0.03 % (measured +0.002, +0.010, +0.019, +0.017 %), 10x less although
    three times as many modes are quasi-static; frequencies within 0.1 % (below)."""
    out = {}
    for key, sets in (("all", ["plant.quasi_static_hz=1e9"]),
                      ("euler", ["plant.quasi_static_hz=10500", "plant.quasi_static_theta=0"]), ("default", [])):
        m = build_plant(load(sets=sets))
        n = int(round(2.0 / m.cfg.dt_s))
        F = hammer_force(n, m.cfg.dt_s, 10.0, 0.5e-3)
        Y, _, _ = run(m, F, 100.0, x0=m.initial_state(100.0))
        freq, H = accelerance_frf(F, _series(m, Y, "a_frf"), m.cfg.dt_s, 0.5)
        f0 = stuck_frequencies_hz(m, preloaded_pairs(m, 100.0))[[k - 1 for k in MODES]]
        out[key] = identify(freq, H, f0, 0.5)
    (f_all, z_all), (_, z_euler), (f_qs, z_qs) = out["all"], out["euler"], out["default"]
    # frequencies within 0.1 %: measured 6.1e-4 at mode 5 (the model with every mode stepped leaves its
    # modes from omega h = 1, 3.3 kHz, unmatched: docs/plant.md 2.2; 4.3e-4 with the plain trapezoid)
    np.testing.assert_allclose(f_qs, f_all, rtol=1e-3)
    assert np.all(z_qs >= z_all - 1e-5) and np.all(z_qs - z_all < 3e-4), (z_all, z_qs)
    assert np.max(z_euler - z_all) > 1e-3, (z_all, z_euler)   # the lag theta removes is real


def test_one_substep_is_converged_with_interface_damping():
    """Stick-slip every cycle (5 N sine at 223.6 Hz, F_N1 = 40 N): one substep per controller
    step (the default: modes above 10.5 kHz quasi-static) gives the first harmonic of 16
    substeps with every mode stepped within 2 % (measured 1.3 %: the quasi-static modes' h/2 lag,
    docs/plant.md 2.6), and the acceleration is not swamped by unresolved modes (without
    interface damping 97 % of its energy lay above 5 kHz and the run was not converged)."""
    from frictionrt.rt.loop import first_harmonic_amplitude
    res = {}
    for sub in (1, 16):
        cfg = load(sets=[f"plant.substeps={sub}"] + (["plant.quasi_static_hz=1e9"] if sub > 1 else []))
        m = build_plant(cfg)
        n = int(round(1.0 / cfg.dt_s))
        F = 5.0 * np.sin(2 * np.pi * 223.6 * np.arange(n) * cfg.dt_s)
        Y, _, _ = run(m, F, 40.0)
        tail = slice(n - n // 5, n)
        w = _series(m, Y, "w_frf")[tail]
        a = _series(m, Y, "a_frf")[tail]
        res[sub] = first_harmonic_amplitude(w, 223.6, cfg.dt_s)
        if sub == 1:
            A = np.abs(np.fft.rfft(a))
            f = np.fft.rfftfreq(len(a), cfg.dt_s)
            assert (A[f > 5000] ** 2).sum() / (A**2).sum() < 0.3
    assert res[1] == pytest.approx(res[16], rel=2e-2)


def test_joint_converges_in_its_contact_pitch():
    """docs/plant.md 6.2: the contact per unit area, refined in its pitch (benchmarks.contact_pitch),
    gives preloaded stuck modes 2-9 at F_N1 = 100 N of the full model that converge: 2.5 mm lies
    within 0.07 % of 1.25 mm (measured; 0.15 % allowed), and the refinement's step shrinks (2.5 ->
    1.25 mm at most half of 10 -> 2.5 mm on every mode). A uniform 10 mm pitch lies 0.87 % above on
    mode 5 (measured; 0.5..1.2 % required); the default, 10 mm with 5 mm points within 30 mm of both
    ends (docs/plant.md 6.3), gives 5 mm everywhere's modes (to 2e-6; 1e-5 allowed) and lies within
    issue 31's 0.3 % of 1.25 mm (measured 0.28 %, mode 3): its discretisation error."""
    from benchmarks.contact_pitch import refined
    base = load()

    def modes(pitch):
        """Stuck modes 1-9 at ``pitch`` everywhere, or at the default layout (None)."""
        cfg = with_sets(base, ["plant.reduced=false"]) if pitch is None else refined(base, ["plant.reduced=false"], pitch)
        model = build_plant(cfg)
        return stuck_frequencies_hz(model, preloaded_pairs(model, 100.0))[:9]

    # modes 2-9: mode 1 (9.7 Hz) is resolved only to eps lambda_max / (2 lambda_1) = 0.6 % at 1.25 mm
    # (lambda_max 2e17 1/s^2 there; docs/plant.md 6), and barely involves the joint
    f10, f2, f1 = (modes(p)[1:] for p in (base.plant.interface.pitch_m, 0.0025, 0.00125))
    assert base.plant.interface.pitch_m == 0.01
    assert np.max(np.abs(f2 / f1 - 1)) < 1.5e-3
    assert np.all(np.abs(f2 - f1) < 0.5 * np.abs(f10 - f2))
    assert 0.005 < np.max(f10 / f1 - 1) < 0.012
    f_default, f5 = modes(None)[1:], modes(0.005)[1:]
    assert np.max(np.abs(f_default / f5 - 1)) < 1e-5 and np.max(np.abs(f_default / f1 - 1)) < 3e-3
    # the elements are not what moves: the same 1.25 mm points on 5 mm elements (three of every four
    # points between nodes, read through the elements' interpolation) give modes 2-9 within 0.017 %
    # of the 1.25 mm elements (measured; 0.03 % allowed), a tenth of the 2.5 -> 1.25 mm pitch's step
    coarse = build_plant(load(sets=["plant.reduced=false", "plant.interface.pitch_m=0.00125",
                                    "plant.element_length_m=0.005"]))
    f1e = stuck_frequencies_hz(coarse, preloaded_pairs(coarse, 100.0))[1:9]
    assert np.max(np.abs(f1e / f1 - 1)) < 3e-4


def test_hammer_test_step_error_after_period_matching():
    """docs/plant.md 2.2 and 6.2 (benchmarks.substep_convergence): the 50 N hammer test's a_frf
    accelerance over 50-1200 Hz against 8 substeps, with the modes period-matched. All but stuck (mu
    = 2, 300 N) and slipping (100 N) the error falls with every halving (measured on the graded
    joint 1.04 -> 0.89 -> 0.23 dB and 0.44 -> 0.35 -> 0.04 dB at 1, 2, 4 substeps; on the uniform
    10 mm joint 0.88 -> 0.43 -> 0.06 and 0.53 -> 0.37 -> 0.05 dB; before period matching, on the 20 mm
    plant, the slipping test gave 4.39 -> 2.47 -> 1.31 dB), one substep's error stays near 1 dB (1.2
    allowed), and the slipping test's is still 2.7 x the signature of micro_slip at its default
    strength (0.16 dB measured; 2 x required): the step's error, not the effect, is what a diagnosis
    at one substep sees first."""
    from benchmarks.substep_convergence import accelerance, rms_db
    from frictionrt.rt.discrepancy.effects import get
    base = load()

    def errors(cfg, F_N1):
        H = {s: accelerance(with_sets(cfg, [f"plant.substeps={s}"]), F_N1) for s in (1, 2, 4, 8)}
        return np.array([rms_db(H[s], H[8]) for s in (1, 2, 4)]), H[1]

    stuck, _ = errors(with_sets(base, ["plant.interface.mu=2.0"]), 300.0)
    slip, H1 = errors(base, 100.0)
    for e in (stuck, slip):
        assert np.all(np.diff(e) < 0) and e[0] < 1.2, e
    ms = get("micro_slip")
    signature = rms_db(accelerance(ms.apply(base, ms.parameter.default), 100.0), H1)
    assert slip[0] > 2.0 * signature, (slip, signature)

def test_a_graded_contact_layout_equals_the_uniform_one_where_the_middle_stays_open():
    """docs/plant.md 6.4: the pitch matters only where the joint is closed, near the screws at both
    ends; between them the beams stand apart (0.2..1.5 um at 100 N). 2.5 mm points within 30 mm of
    both ends and 10 mm points between (end_refinement 4: 35 points) give the 50 N hammer test at
    100 N of 2.5 mm points everywhere (65) to 0.0006 dB rms (measured; 0.02 dB allowed) and its
    modes 2-5 to 1e-6 (1e-4 allowed), while 10 mm points everywhere are 1.6 dB and 0.75 % away."""
    from benchmarks.joint_convergence import hammer, rms_db
    uniform = load(sets=["plant.interface.pitch_m=0.0025", "plant.interface.end_refinement=1",
                         "plant.element_length_m=0.0025"])
    graded = load(sets=["plant.interface.end_refinement=4", "plant.interface.end_zone_m=0.03",
                        "plant.element_length_m=0.0025"])
    coarse = load(sets=["plant.interface.end_refinement=1"])
    r_u, r_g, r_c = hammer(uniform, 100.0), hammer(graded, 100.0), hammer(coarse, 100.0)
    assert build_plant(graded).n_pairs == 35
    assert rms_db(r_g["H"], r_u["H"]) < 0.02 and np.max(np.abs(r_g["f"] / r_u["f"] - 1)) < 1e-4
    assert rms_db(r_c["H"], r_u["H"]) > 1.0 and np.max(np.abs(r_c["f"] / r_u["f"] - 1)) > 5e-3
