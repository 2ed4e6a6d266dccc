"""Sensors (plant/sensors.py) and the seeded noise source (rt/common/noise.py): filters against closed-form
responses, the leaky integrator against 1/(i w + w_c), ADC steps and clipping, noise statistics
within their standard errors, determinism, and the kernels against plain NumPy / Python
references.

Statistical tolerances are 4 standard errors (a false failure has probability ~6e-5 for a
fresh seed; the seeds here are fixed, so the outcome is deterministic).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal as ss
import scipy.stats as st

from frictionrt.rt.common.config import load, with_sets
from tests.nrt_probe import assert_no_allocation_per_step
from frictionrt.rt.common.noise import _fill_u64, new_rng, normals, splitmix64
from frictionrt.plant.sensors import (
    SENSOR_OUTPUTS,
    SENSOR_SLOTS,
    _sensors_run,
    _sensors_step,
    build_sensors,
    initial_state,
    output_index,
    run_sensors,
    sensors_step,
    slot_index,
)

OUT = output_index()
SL = slot_index()
MASK = (1 << 64) - 1
N_STAT = 100_000


@pytest.fixture(scope="module")
def cfg():
    # a +-500 m/s^2 accelerometer range (the default is +-5000): the LSB (0.015 m/s^2) then
    # lies near the noise (0.01 m/s^2), so both noise and quantisation are visible in the tests
    return load(sets=["sensors.acc_range=500"])


@pytest.fixture(scope="module")
def p(cfg):
    return build_sensors(cfg)


# --- reference generator (Python integers, from the published C code) -----------------------

def xoshiro_ref(seed: int, n: int) -> list[int]:
    """xoshiro256** outputs, seeded with splitmix64 (prng.di.unimi.it reference code)."""
    def rotl(x, k):
        return ((x << k) | (x >> (64 - k))) & MASK
    s = list(splitmix64(seed, 4))
    out = []
    for _ in range(n):
        out.append((rotl((s[1] * 5) & MASK, 7) * 9) & MASK)
        t = (s[1] << 17) & MASK
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = rotl(s[3], 45)
    return out


def normals_ref(seed: int, n_pairs: int) -> np.ndarray:
    """Box-Muller pairs from the reference uniforms: (n_pairs, 2)."""
    u = np.array(xoshiro_ref(seed, 2 * n_pairs), dtype=object)
    u = np.array([(int(v) >> 11) * 2.0**-53 for v in u]).reshape(n_pairs, 2)
    rho = np.sqrt(-2.0 * np.log(1.0 - u[:, 0]))
    return np.column_stack([rho * np.cos(2 * np.pi * u[:, 1]), rho * np.sin(2 * np.pi * u[:, 1])])


# --- noise ------------------------------------------------------------------------------------

def test_splitmix64_and_xoshiro_match_reference_code():
    # splitmix64 from 0: first output 0xE220A8397B1DCDAF (the published value)
    assert splitmix64(0, 1)[0] == 0xE220A8397B1DCDAF
    for seed in (0, 1, 12345, 2**63 + 7):
        s = new_rng(seed)
        out = np.empty(1000, np.uint64)
        _fill_u64(s, out)
        assert [int(v) for v in out] == xoshiro_ref(seed, 1000)


def test_normals_are_box_muller_of_the_uniforms():
    # same formula on the reference uniforms: equal to a few ulp (libm vs numba's math)
    z = normals(new_rng(5), 2000).reshape(-1, 2)
    ref = normals_ref(5, 1000)
    assert np.all(np.abs(z - ref) <= 1e-13 * np.maximum(1.0, np.abs(ref)))


def test_normal_statistics():
    # 1e5 samples: mean within 4 sigma/sqrt(N) = 0.0126; variance within 4 sqrt(2/N) = 0.0179;
    # Kolmogorov-Smirnov against N(0, 1) not rejected at 1e-3; consecutive (pair) numbers
    # uncorrelated within 4/sqrt(N/2)
    z = normals(new_rng(2024), N_STAT)
    n = len(z)
    assert abs(z.mean()) <= 4 / math.sqrt(n)
    assert abs(z.var(ddof=1) - 1) <= 4 * math.sqrt(2 / (n - 1))
    assert st.kstest(z, "norm").pvalue > 1e-3
    a, b = z[0::2], z[1::2]
    assert abs(np.corrcoef(a, b)[0, 1]) <= 4 / math.sqrt(len(a))
    # uniforms: in [0, 1), mean 1/2 within 4 SE (SE = sqrt(1/12 / N))
    s = new_rng(99)
    raw = np.empty(N_STAT, np.uint64)
    _fill_u64(s, raw)
    u = (raw >> np.uint64(11)).astype(float) * 2.0**-53
    assert u.min() >= 0.0 and u.max() < 1.0
    assert abs(u.mean() - 0.5) <= 4 * math.sqrt(1 / 12 / N_STAT)


def test_noise_is_reproducible_and_seeded():
    a1 = normals(new_rng(7), 1000)
    a2 = normals(new_rng(7), 1000)
    b = normals(new_rng(8), 1000)
    assert np.array_equal(a1, a2)                    # bit-identical for the same seed
    assert np.mean(a1 == b) < 1e-3                   # another seed: another sequence
    s = new_rng(7)
    first = normals(s, 500)
    second = normals(s, 500)                         # the state advanced in place
    assert np.array_equal(np.concatenate([first, second]), a1)
    with pytest.raises(ValueError, match="non-negative integer"):
        new_rng(-1)
    with pytest.raises(ValueError, match="non-negative integer"):
        new_rng(True)
    with pytest.raises(ValueError, match="all zero"):
        normals(np.zeros(4, np.uint64), 1)


def test_noise_does_not_touch_numbas_global_rng():
    import numba

    @numba.njit
    def global_draw(seed):
        np.random.seed(seed)
        return np.random.random()

    r0 = global_draw(3)
    normals(new_rng(1), 10)
    assert global_draw(3) == r0
    np.random.seed(0)
    x = normals(new_rng(4), 10)
    np.random.seed(1)
    assert np.array_equal(x, normals(new_rng(4), 10))


# --- filters and integrator -------------------------------------------------------------------

def quiet(bits=24, **more):
    """Configuration without sensor noise and with a fine ADC (deterministic filter checks)."""
    sets = ["sensors.acc_noise_rms=0.0", "sensors.strain_noise_N=0.0", "sensors.cell_noise_N=0.0",
            f"sensors.adc_bits={bits}"] + [f"sensors.{k}={v}" for k, v in more.items()]
    return load(sets=sets)


def first_order_ramp_step(t, w, T, H):
    """Response at t >= 0 of y' = w (u - y), y(0) = 0, to the input rising linearly from 0 at
    t = 0 to H at t = T and constant afterwards (a sampled step joined by a straight line)."""
    yT = H * (1 - (1 - np.exp(-w * T)) / (w * T))
    ramp = H / T * (t - (1 - np.exp(-w * t)) / w)
    return np.where(t <= T, ramp, H - (H - yT) * np.exp(-w * (t - T)))


def butterworth_unit_ramp(t, w):
    """Response of w^2/(s^2 + sqrt(2) w s + w^2) to the unit ramp u = t (t >= 0), by residues:
    Y(s) = w^2 / (s^2 (s^2 + sqrt(2) w s + w^2)) = 1/s^2 - sqrt(2)/(w s) + sum_p r_p / (s - p)."""
    poles = np.roots([1, np.sqrt(2) * w, w**2])
    t = np.maximum(t, 0.0)
    y = t - np.sqrt(2) / w + 0j
    for pk in poles:
        y = y + w**2 / (pk**2 * (2 * pk + np.sqrt(2) * w)) * np.exp(pk * t)
    return np.where(t > 0, y.real, 0.0)


def test_first_order_force_filters_step_exact_at_samples(cfg):
    # F_N1 steps 100 -> 300 N at tick k0. The sensors join samples by straight lines (first-
    # order hold), so the analog input is a ramp over [t_{k0-1}, t_k0]; the filters' states must
    # equal the closed-form response at every sample to 1e-12 of the 200 N step.
    c = quiet()
    pp = build_sensors(c)
    dt = c.dt_s
    n, k0 = 400, 5
    F = np.where(np.arange(n) >= k0, 300.0, 100.0)
    U = np.column_stack([np.zeros(n), np.zeros(n), F])
    X, Y = run_sensors(pp, U, new_rng(0), initial_state(pp, 0.0, 0.0, 100.0))
    t = (np.arange(n) - (k0 - 1)) * dt                       # time since the ramp started
    for slot, out, f_hz in (("F_strain_y", "F_strain", c.sensors.strain_bandwidth_hz),
                            ("F_cell_y", "F_cell", c.sensors.cell_bandwidth_hz)):
        w = 2 * np.pi * f_hz
        ref = 100.0 + np.where(t > 0, first_order_ramp_step(np.maximum(t, 0), w, dt, 200.0), 0.0)
        assert np.abs(X[1:, SL[slot]] - ref).max() <= 1e-12 * 200.0
        # reading = ADC(filter): within half an LSB without noise
        assert np.abs(Y[:, OUT[out]] - ref).max() <= 0.5 * pp.force_lsb * (1 + 1e-9)


def test_accelerometer_filter_sampled_step_exact(cfg):
    # Same for the 2nd-order Butterworth (5 kHz): the sampled step is the difference of two
    # ramps of slope H/dt; closed form by residues. 1e-12 of the step.
    c = quiet()
    pp = build_sensors(c)
    dt = c.dt_s
    n, k0, H = 60, 3, 7.5
    a = np.where(np.arange(n) >= k0, H, 0.0)
    U = np.column_stack([a, -a, np.zeros(n)])
    X, _ = run_sensors(pp, U, new_rng(0), initial_state(pp))
    w = 2 * np.pi * c.sensors.acc_bandwidth_hz
    t = (np.arange(n) - (k0 - 1)) * dt
    ref = H / dt * (butterworth_unit_ramp(t, w) - butterworth_unit_ramp(t - dt, w))
    assert np.abs(X[1:, SL["acc_tip_y"]] - ref).max() <= 1e-12 * H
    assert np.abs(X[1:, SL["acc_frf_y"]] + ref).max() <= 1e-12 * H


def first_harmonic(x, f, dt):
    n = len(x)
    t = np.arange(n) * dt
    return 2 / n * np.sum(x * np.exp(-2j * np.pi * f * t))


def test_leaky_integrator_gain_and_phase_at_50_hz(cfg):
    # 50 Hz, 10 m/s^2 at the tip, no noise, 24-bit ADC; 2 s, the last second analysed (50 whole
    # periods of 420 samples; the 2 Hz transient has decayed to e^-12.6). Required 1 % (issue):
    #   v_tip / a_tip_meas           = 1 / (i w + w_c)                       measured ~2e-5
    #   v_tip / a_tip (plant)        = H_bw(i w) / (i w + w_c)                measured ~2e-5
    # (the first-order hold's error is ~(w dt)^2 / 12 = 1.9e-5; a zero-order hold would be
    # ~w dt / 2 = 7.5e-3)
    c = quiet()
    pp = build_sensors(c)
    dt = c.dt_s
    f = 50.0
    n = 2 * 21000
    t = np.arange(1, n + 1) * dt
    U = np.column_stack([10 * np.sin(2 * np.pi * f * t), np.zeros(n), np.zeros(n)])
    _, Y = run_sensors(pp, U, new_rng(0), initial_state(pp))
    last = slice(n // 2, n)
    A_in = first_harmonic(U[last, 0], f, dt)
    A_m = first_harmonic(Y[last, OUT["a_tip_meas"]], f, dt)
    V = first_harmonic(Y[last, OUT["v_tip_meas"]], f, dt)
    w = 2 * np.pi * f
    w_c = 2 * np.pi * c.sensors.velocity_corner_hz
    wb = 2 * np.pi * c.sensors.acc_bandwidth_hz
    H_int = 1 / (1j * w + w_c)
    H_bw = wb**2 / ((1j * w) ** 2 + np.sqrt(2) * wb * 1j * w + wb**2)
    e_int = abs((V / A_m) / H_int - 1)
    e_chain = abs((V / A_in) / (H_bw * H_int) - 1)
    assert e_int <= 1e-4 and e_chain <= 1e-4, (e_int, e_chain)
    # the 1 % stated explicitly on gain and phase
    assert abs(abs(V / A_m) / abs(H_int) - 1) <= 0.01
    assert abs(np.angle((V / A_m) / H_int)) <= 0.01


def test_leaky_integrator_does_not_drift(cfg):
    # a constant accelerometer offset b gives the bounded v = b / w_c (not a ramp): 0.01 m/s^2
    # -> 0.796 mm/s after ~10 / w_c; exact steady state of the discretisation to 1e-12
    c = quiet()
    pp = build_sensors(c)
    b = 0.01
    n = int(2.0 / c.dt_s)
    U = np.column_stack([np.full(n, b), np.zeros(n), np.zeros(n)])
    _, Y = run_sensors(pp, U, new_rng(0), initial_state(pp))
    w_c = 2 * np.pi * c.sensors.velocity_corner_hz
    a_meas = Y[-1, OUT["a_tip_meas"]]                        # b on the 24-bit grid
    assert Y[-1, OUT["v_tip_meas"]] == pytest.approx(a_meas / w_c, rel=1e-9)
    assert np.abs(Y[:, OUT["v_tip_meas"]]).max() <= a_meas / w_c * (1 + 1e-6)   # bounded: no drift


def test_force_sensors_from_the_actuator_vs_sampled_F_N1(cfg):
    # A 230 Hz bang-bang 0/150 V command through a 1 kHz 2nd-order setpoint filter (the kind of
    # drive the Lyapunov law gives) rings the stack at 7.1 kHz. (a) u = (.., F_strain_a,
    # F_cell_a) from the actuator: readings = ADC(analog value), within half an LSB without
    # noise. (b) u = (.., F_N1): the same filters on the 21 kHz samples of F_N1 miss the ringing
    # between samples: measured 0.59 N (strain) and 0.71 N (cell) rms error after the start;
    # asserted > 0.2 N, i.e. 4x the cell's 0.05 N noise: why the loop should pass (a).
    from frictionrt.plant.actuator import build_actuator, run_actuator
    from frictionrt.plant.actuator import initial_state as act_initial
    from frictionrt.plant.actuator import output_index as act_index
    c = quiet()
    ps = build_sensors(c)
    pa = build_actuator(c)
    ai = act_index()
    n = 2100
    t = np.arange(n) * c.dt_s
    raw = np.where(np.sin(2 * np.pi * 230 * t) > 0, 150.0, 0.0)
    b, a = ss.butter(2, 1000, fs=1 / c.dt_s)
    _, Ya = run_actuator(pa, ss.lfilter(b, a, raw - 75) + 75, act_initial(pa, 75.0))
    F, Fs_a, Fc_a = Ya[:, ai["F_stack"]], Ya[:, ai["F_strain_a"]], Ya[:, ai["F_cell_a"]]
    z = np.zeros(n)
    x0 = initial_state(ps, 0.0, 0.0, F[0])
    _, Y4 = run_sensors(ps, np.column_stack([z, z, Fs_a, Fc_a]), new_rng(0), x0)
    _, Y3 = run_sensors(ps, np.column_stack([z, z, F]), new_rng(0), x0)
    half = 0.5 * ps.force_lsb * (1 + 1e-9)
    assert np.abs(Y4[:, OUT["F_strain"]] - Fs_a).max() <= half
    assert np.abs(Y4[:, OUT["F_cell"]] - Fc_a).max() <= half
    late = slice(100, n)
    for out, exact in (("F_strain", Fs_a), ("F_cell", Fc_a)):
        rms = np.sqrt(np.mean((Y3[late, OUT[out]] - exact[late]) ** 2))
        assert 0.2 < rms < 2.0, (out, rms)


# --- ADC ---------------------------------------------------------------------------------------

def test_adc_step_and_clipping():
    # 8-bit ADC (visible steps): LSB = range / 2^bits (two's complement +-acc_range, straight
    # binary 0..force_range_N): accelerometers 1000/256 = 3.906 m/s^2, forces 1000/256 N.
    # Readings lie on the code grid, zero is a code, full scale clips at the end codes
    # (-acc_range and acc_range - LSB; 0 and force_range_N - LSB).
    c = quiet(bits=8)
    pp = build_sensors(c)
    s = c.sensors
    assert pp.acc_lsb == 2 * s.acc_range / 2**8 and pp.force_lsb == s.force_range_N / 2**8
    levels = np.array([-800.0, -500.0, -3.0, -1.9, 0.0, 1.9, 2.0, 250.0, 498.1, 500.0, 900.0])
    forces = np.array([-50.0, 0.0, 1.9, 2.0, 100.0, 500.0, 996.0, 998.0, 1000.0, 5000.0, 40.0])
    for a, F in zip(levels, forces):
        n = 2000                                             # settle every filter (0.095 s)
        U = np.column_stack([np.full(n, a), np.full(n, -a), np.full(n, F)])
        _, Y = run_sensors(pp, U, new_rng(0), initial_state(pp, a, -a, F))
        for val, inp, lsb, lo, hi in ((Y[-1, OUT["a_tip_meas"]], a, pp.acc_lsb, -s.acc_range, s.acc_range),
                                      (Y[-1, OUT["a_frf_meas"]], -a, pp.acc_lsb, -s.acc_range, s.acc_range),
                                      (Y[-1, OUT["F_strain"]], F, pp.force_lsb, 0.0, s.force_range_N),
                                      (Y[-1, OUT["F_cell"]], F, pp.force_lsb, 0.0, s.force_range_N)):
            assert val / lsb == np.rint(val / lsb)                       # on the grid
            expect = min(max(np.rint(inp / lsb) * lsb, lo), hi - lsb)    # nearest code, clipped
            assert val == pytest.approx(expect, abs=1e-9), (inp, val, expect)
    # a slow ramp over the force range steps by exactly one LSB at a time
    n = 60000
    F = np.linspace(-10, 1010, n)
    U = np.column_stack([np.zeros(n), np.zeros(n), F])
    _, Y = run_sensors(pp, U, new_rng(0), initial_state(pp, 0.0, 0.0, F[0]))
    steps = np.unique(np.round(np.diff(Y[:, OUT["F_cell"]]) / pp.force_lsb, 9))
    assert set(steps) == {0.0, 1.0}
    assert Y[:, OUT["F_cell"]].max() == s.force_range_N - pp.force_lsb
    assert Y[:, OUT["F_cell"]].min() == 0.0


def test_nan_input_stays_visible(p):
    x = initial_state(p)
    xn, y = np.empty(len(SENSOR_SLOTS)), np.empty(len(SENSOR_OUTPUTS))
    sensors_step(0, x, np.array([np.nan, 0.0, 100.0]), p, xn, y, new_rng(0))
    assert np.isnan(y[OUT["a_tip_meas"]]) and np.isfinite(y[OUT["a_frf_meas"]])


# --- noise at the sensor outputs --------------------------------------------------------------

def test_sensor_noise_rms_within_standard_error(cfg, p):
    # Constant inputs for 1e5 ticks, default configuration. Reading = ADC(x + sigma N): its
    # variance is sigma^2 + LSB^2/12 (Sheppard; exact to exp(-2 pi^2 sigma^2 / LSB^2) < 3e-4
    # relative for these sigma / LSB >= 0.65). Tolerance on the rms: 4 standard errors,
    # SE(rms) = rms / sqrt(2 (N - 1)). Means within 4 rms / sqrt(N). Channels uncorrelated.
    s = cfg.sensors
    a_tip, a_frf, F = 1.2345, -3.21, 300.0
    U = np.tile([a_tip, a_frf, F], (N_STAT, 1))
    _, Y = run_sensors(p, U, new_rng(cfg.rt.seed), initial_state(p, a_tip, a_frf, F))
    for out, inp, sigma, lsb in (("a_tip_meas", a_tip, s.acc_noise_rms, p.acc_lsb),
                                 ("a_frf_meas", a_frf, s.acc_noise_rms, p.acc_lsb),
                                 ("F_strain", F, s.strain_noise_N, p.force_lsb),
                                 ("F_cell", F, s.cell_noise_N, p.force_lsb)):
        v = Y[:, OUT[out]]
        rms_expect = math.sqrt(sigma**2 + lsb**2 / 12)
        se = rms_expect / math.sqrt(2 * (N_STAT - 1))
        assert abs(v.std(ddof=1) - rms_expect) <= 4 * se, (out, v.std(ddof=1), rms_expect)
        assert abs(v.mean() - inp) <= 4 * rms_expect / math.sqrt(N_STAT), out
    r = np.corrcoef(Y[:, [OUT["a_tip_meas"], OUT["a_frf_meas"], OUT["F_strain"], OUT["F_cell"]]].T)
    assert np.all(np.abs(r[np.triu_indices(4, 1)]) <= 4 / math.sqrt(N_STAT))


def test_sensor_noise_without_quantisation():
    # 24-bit ADC: the reading's rms is the configured sigma alone (LSB^2/12 < 1e-9 sigma^2)
    c = load(sets=["sensors.adc_bits=24"])
    pp = build_sensors(c)
    U = np.tile([0.5, 0.25, 200.0], (N_STAT, 1))
    _, Y = run_sensors(pp, U, new_rng(11), initial_state(pp, 0.5, 0.25, 200.0))
    for out, sigma in (("a_tip_meas", c.sensors.acc_noise_rms), ("F_strain", c.sensors.strain_noise_N),
                       ("F_cell", c.sensors.cell_noise_N)):
        se = sigma / math.sqrt(2 * (N_STAT - 1))
        assert abs(Y[:, OUT[out]].std(ddof=1) - sigma) <= 4 * se, out


# --- determinism ------------------------------------------------------------------------------

def test_same_seed_bit_identical_other_seed_only_noise(cfg, p):
    n = 5000
    t = np.arange(1, n + 1) * cfg.dt_s
    U = np.column_stack([30 * np.sin(2 * np.pi * 230 * t), 12 * np.sin(2 * np.pi * 230 * t + 1),
                         300 + 200 * np.sin(2 * np.pi * 40 * t)])
    x0 = initial_state(p, 0.0, 0.0, 300.0)
    r1, r2, r3 = new_rng(cfg.rt.seed), new_rng(cfg.rt.seed), new_rng(cfg.rt.seed + 1)
    X1, Y1 = run_sensors(p, U, r1, x0)
    X2, Y2 = run_sensors(p, U, r2, x0)
    X3, Y3 = run_sensors(p, U, r3, x0)
    assert np.array_equal(X1, X2) and np.array_equal(Y1, Y2) and np.array_equal(r1, r2)
    # another seed: the noise-free filter states are identical, the readings differ by noise
    # and quantisation only (<= 6 sigma sqrt(2) + 1 LSB)
    clean = [SL[k] for k in ("acc_tip_y", "acc_tip_r", "acc_frf_y", "acc_frf_r", "F_strain_y", "F_cell_y")]
    assert np.array_equal(X1[:, clean], X3[:, clean])
    s = cfg.sensors
    assert not np.array_equal(Y1, Y3)
    for out, sigma, lsb in (("a_tip_meas", s.acc_noise_rms, p.acc_lsb), ("F_strain", s.strain_noise_N, p.force_lsb),
                            ("F_cell", s.cell_noise_N, p.force_lsb)):
        assert np.abs(Y1[:, OUT[out]] - Y3[:, OUT[out]]).max() <= 6 * math.sqrt(2) * sigma + lsb


# --- kernel vs plain NumPy reference ----------------------------------------------------------

def reference_run(cfg, U, seed, x0):
    """The sensor chain written from plant/sensors.py's docstring with NumPy and the Python-integer
    generator: filters by scipy.signal.cont2discrete('foh') state-space recursions, noise from
    normals_ref, ADC clip(rint(v / LSB), n_lo, n_hi) LSB."""
    s = cfg.sensors
    dt = cfg.dt_s
    n = len(U)
    Z = normals_ref(seed, 2 * n).reshape(n, 4)               # per tick: tip, frf, strain, cell

    def foh(A, B):
        # scipy's FOH returns a model with state xi = x - Gamma1 u_k (output y = C xi + D u);
        # run it as such
        return ss.cont2discrete((A, B, np.eye(A.shape[0]), np.zeros((A.shape[0], 1))), dt, method="foh")[:4]

    def filt(A, B, u, x_start, u_start):
        Ad, Bd, Cd, Dd = foh(np.atleast_2d(A), np.atleast_2d(B).reshape(-1, 1))
        xi = np.linalg.solve(Cd, np.atleast_1d(x_start) - Dd[:, 0] * u_start)
        out = np.empty((len(u), Ad.shape[0]))
        uu = np.concatenate([[u_start], u])
        for k in range(len(u)):
            xi = Ad @ xi + Bd[:, 0] * uu[k]
            out[k] = Cd @ xi + Dd[:, 0] * uu[k + 1]
        return out

    def adc(v, lsb, lo, hi):
        return np.clip(np.rint(v / lsb), lo, hi) * lsb

    w = 2 * np.pi * s.acc_bandwidth_hz
    Abw, Bbw = np.array([[0, w], [-w, -np.sqrt(2) * w]]), np.array([0, w])
    nb = 2**s.adc_bits
    acc = (2 * s.acc_range / nb, -nb // 2, nb // 2 - 1)
    frc = (s.force_range_N / nb, 0, nb - 1)
    tip = filt(Abw, Bbw, U[:, 0], x0[0:2], x0[4])
    frf = filt(Abw, Bbw, U[:, 1], x0[2:4], x0[5])
    a_tip_m = adc(tip[:, 0] + s.acc_noise_rms * Z[:, 0], *acc)
    a_frf_m = adc(frf[:, 0] + s.acc_noise_rms * Z[:, 1], *acc)
    w_c = 2 * np.pi * s.velocity_corner_hz
    v = filt(-w_c, 1.0, a_tip_m, x0[6], x0[7])[:, 0]
    ws, wc = 2 * np.pi * s.strain_bandwidth_hz, 2 * np.pi * s.cell_bandwidth_hz
    if U.shape[1] == 4:       # analog force-sensor outputs given: noise and ADC only
        Fs, Fc, F_in = U[:, 2], U[:, 3], np.full(n, x0[10])
    else:
        Fs = filt(-ws, ws, U[:, 2], x0[8], x0[10])[:, 0]
        Fc = filt(-wc, wc, U[:, 2], x0[9], x0[10])[:, 0]
        F_in = U[:, 2]
    Y = np.column_stack([a_tip_m, a_frf_m, v, adc(Fs + s.strain_noise_N * Z[:, 2], *frc),
                         adc(Fc + s.cell_noise_N * Z[:, 3], *frc)])
    X = np.column_stack([tip, frf, U[:, 0], U[:, 1], v, a_tip_m, Fs, Fc, F_in])
    return X, Y


def test_kernel_matches_numpy_reference(cfg, p):
    # plant-like inputs (two modes at the accelerometers, clipping excursions, a moving F_N1)
    # with noise; scales: accelerations acc_range, velocity its max, forces force_range_N;
    # 1e-12 relative. Readings are compared code for code (equal up to the scale's round-off).
    n = 3000
    t = np.arange(1, n + 1) * cfg.dt_s
    U = np.column_stack([80 * np.sin(2 * np.pi * 230 * t) + 600 * (np.abs(t - 0.07) < 1e-3),
                         25 * np.sin(2 * np.pi * 388 * t + 0.3),
                         300 + 280 * np.sin(2 * np.pi * 31 * t) + 500 * (np.abs(t - 0.1) < 2e-3)])
    s = cfg.sensors
    x0 = initial_state(p, 0.0, 0.0, 300.0)
    # both input forms: F_N1 filtered here, and analog force-sensor values given (here a
    # strain and a cell signal made up from U)
    U4 = np.column_stack([U[:, :2], U[:, 2] + 3 * np.sin(2 * np.pi * 900 * t), U[:, 2] - 2.0])
    for UU in (U, U4):
        X, Y = run_sensors(p, UU, new_rng(cfg.rt.seed), x0)
        Xr, Yr = reference_run(cfg, UU, cfg.rt.seed, x0)
        v_scale = np.abs(Xr[:, 6]).max()
        xs = np.array([s.acc_range, s.acc_range, s.acc_range, s.acc_range, s.acc_range, s.acc_range, v_scale,
                       s.acc_range, s.force_range_N, s.force_range_N, s.force_range_N])
        assert np.all(np.abs(X[1:] - Xr) <= 1e-12 * xs), np.abs(X[1:] - Xr).max(axis=0) / xs
        ys = np.array([s.acc_range, s.acc_range, v_scale, s.force_range_N, s.force_range_N])
        assert np.all(np.abs(Y - Yr) <= 1e-12 * ys), np.abs(Y - Yr).max(axis=0) / ys
        assert Y[:, OUT["a_tip_meas"]].max() == s.acc_range - p.acc_lsb   # the pulse clipped


# --- run-time properties ----------------------------------------------------------------------

def test_checked_wrapper(p):
    x = initial_state(p)
    xn, y = np.empty(len(SENSOR_SLOTS)), np.empty(len(SENSOR_OUTPUTS))
    with pytest.raises(ValueError, match="state must have shape"):
        sensors_step(0, x[:-1], np.zeros(3), p, xn, y, new_rng(0))
    with pytest.raises(ValueError, match="a_tip"):
        sensors_step(0, x, np.zeros(2), p, xn, y, new_rng(0))
    with pytest.raises(ValueError, match="a_tip"):
        sensors_step(0, x, np.zeros(6), p, xn, y, new_rng(0))
    with pytest.raises(ValueError, match="uint64"):
        sensors_step(0, x, np.zeros(3), p, xn, y, np.zeros(4))
    sensors_step(0, x, np.zeros(3), p, xn, y, new_rng(0))
    assert np.all(np.isfinite(y))
    sensors_step(0, x, np.array([0.0, 0.0, 100.0, 100.0]), p, xn, y, new_rng(0))
    assert np.all(np.isfinite(y))


def test_kernels_are_cached_nogil_without_refcounting():
    from frictionrt.plant import sensors
    from frictionrt.rt.common import noise
    for f in (sensors._sensors_step, sensors._adc, noise._next_u64, noise._uniform, noise._normal_pair,
              noise._fill_normal, noise._fill_u64):
        assert f.targetoptions.get("nogil") is True, f.__name__
        assert f.targetoptions.get("_nrt") is False, f.__name__
        assert type(f._cache).__name__ == "FunctionCache", f.__name__
    assert type(_sensors_run._cache).__name__ == "FunctionCache"


def test_sensor_step_does_not_allocate():
    # 10 vs 3000 compiled steps under numba's allocation counters (tests/nrt_probe.py)
    assert_no_allocation_per_step("""
        import numba, numpy as np
        from frictionrt.rt.common.config import load
        from frictionrt.rt.common.noise import new_rng
        from frictionrt.plant.sensors import _sensors_step, build_sensors, initial_state

        @numba.njit
        def many(x, xn, U, p, y, rng):
            for k in range(U.shape[0]):
                if k % 2 == 0:
                    _sensors_step(k, x, U[k], p, xn, y, rng)
                else:
                    _sensors_step(k, xn, U[k], p, x, y, rng)

        p = build_sensors(load())
        U = np.random.default_rng(0).normal(size=(3000, 3)) * [50.0, 20.0, 100.0] + [0.0, 0.0, 300.0]
        x, xn, y, rng = initial_state(p), np.empty(11), np.empty(5), new_rng(0)

        def call(n):
            many(x, xn, U[:n], p, y, rng)
    """, n_steps=3000)


def test_step_time(p):
    # loose bound (noisy shared machine); measured figure in docs/actuator_sensors.md
    import numba

    from frictionrt.rt.common.clock import _now_ns

    @numba.njit
    def timed(x, xn, U, p, y, rng, ns, ts):
        for k in range(U.shape[0]):
            t0 = _now_ns(ts)
            _sensors_step(k, x, U[k], p, xn, y, rng)
            ns[k] = _now_ns(ts) - t0
            x, xn = xn, x

    n = 20000
    U = np.random.default_rng(0).normal(size=(n, 3)) * [50.0, 20.0, 100.0] + [0.0, 0.0, 300.0]
    ns = np.empty(n, np.int64)
    args = (initial_state(p), np.empty(11), U, p, np.empty(5), new_rng(0), ns, np.zeros(2, np.int64))
    timed(*args)
    timed(*args)
    assert np.median(ns) < 2000, f"median sensor step {np.median(ns):.0f} ns"


def test_the_bolt_force_readings_add_the_filtered_separation_force(cfg):
    """5-input form (the loop's): the readings are those of the actuator's analog outputs plus the
    strain gauge's and force cell's filters run on the dF_N1 samples (the 3-input form's filters,
    linear), i.e. the sensors read the bolt force F_N1 = F_stack + dF_N1 (noise off; 1 ADC LSB)."""
    q = build_sensors(with_sets(cfg, ["sensors.strain_noise_N=0.0", "sensors.cell_noise_N=0.0"]))
    n = 400
    t = np.arange(n) * cfg.dt_s
    dF = 30.0 * np.sin(2 * np.pi * 380.0 * t) + 5.0 * np.sin(2 * np.pi * 3000.0 * t)
    F_a = 100.0 + 20.0 * np.sin(2 * np.pi * 200.0 * t)
    z = np.zeros(n)
    U5 = np.column_stack([z, z, F_a, F_a, dF])
    _, Y5 = run_sensors(q, U5, new_rng(1))
    _, Y3 = run_sensors(q, np.column_stack([z, z, dF + 300.0]), new_rng(1))   # the filters alone (offset: ADC >= 0)
    oi = output_index()
    for name in ("F_strain", "F_cell"):
        expected = F_a + (Y3[:, oi[name]] - 300.0)
        assert np.max(np.abs(Y5[:, oi[name]] - expected)) <= 2 * q.force_lsb + 1e-9, name
    # not vacuous: the strain gauge's 1 kHz filter attenuates the 3 kHz part the cell passes
    assert np.std(Y5[:, oi["F_strain"]] - F_a) < np.std(Y5[:, oi["F_cell"]] - F_a)
