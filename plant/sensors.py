"""Sensors: what the controller reads each tick, from the plant's and actuator's outputs
(SPEC sections 1 and 3).

    a_tip, a_frf --accelerometer + anti-alias (2nd-order Butterworth, acc_bandwidth_hz)
                 --+ noise (acc_noise_rms)--ADC (adc_bits, +-acc_range)--> a_tip_meas, a_frf_meas
    a_tip_meas   --leaky integrator  v' = a - w_c v,  w_c = 2 pi velocity_corner_hz--> v_tip_meas
    F_N1 --strain gauge (1st order, strain_bandwidth_hz)--> F_strain_a --+ noise--ADC (0..force_range_N)--> F_strain
    F_N1 --piezo force cell (1st order, cell_bandwidth_hz)--> F_cell_a --+ noise--ADC--> F_cell

Three input forms (the kernel tells them apart by len(u)):
    u = (a_tip, a_frf, F_strain_a, F_cell_a, dF_N1)   the loop's: the force sensors' analog
        outputs of the stack force, integrated exactly with the piezo stack by ``frictionrt.plant.actuator``,
        plus the bolt's response to the beams' separation dF_N1 = F_N1 - F_stack (a plant
        output, docs/plant.md 1.4), filtered here on its samples and added, so that the sensors
        measure the bolt force and see the structure's vibration;
    u = (a_tip, a_frf, F_strain_a, F_cell_a)   the same without dF_N1 (here only noise and ADC
        are added);
    u = (a_tip, a_frf, F_N1)   the force sensors' filters run here on the 21 kHz samples of F_N1
        (first-order hold, below). F_N1 rings at the stack's 7.1 kHz between samples, which
        the samples do not resolve: 0.6-0.7 N rms error against the exact analog outputs on a
        230 Hz bang-bang command (a 0.05 N rms cell noise). Kept for inputs that are not the
        actuator's (tests, replays of F_N1).

Continuous filters (y output, u input):
    Butterworth   y' = w r,  r' = w (u - y) - sqrt(2) w r     (y/u = w^2/(s^2 + sqrt(2) w s + w^2))
    first order   y' = w (u - y)
    leaky integr. v' = a - w_c v                               (v/a = 1/(s + w_c))

Discretisation: exact for an input that is linear between samples (first-order hold), from
one matrix exponential (``frictionrt.plant.actuator.discretise``):  z_k = Phi z_{k-1} + G0 u_{k-1} +
G1 (u_k - u_{k-1}). The plant gives its outputs at the sample instants only; joining them by
straight lines keeps the analog sensor's phase, whereas a zero-order hold would shift the signal
by half a sample (23.8 us: 2.0 deg at 230 Hz, 3.4 deg at 400 Hz), four times the phase the
integrator's 2 Hz leak itself costs at 230 Hz (0.5 deg). The previous input sample of each
filter is a state slot. The leaky integrator runs in the controller on the ADC samples and is
discretised the same way (its 50 Hz gain and phase then match 1/(i w + w_c) to 2e-5,
tests/test_sensors.py).

ADC: two's-complement (accelerometers, codes -2^(b-1) .. 2^(b-1) - 1, LSB = 2 acc_range / 2^b)
and straight binary (forces, codes 0 .. 2^b - 1, LSB = force_range_N / 2^b) converters with
round-to-nearest (mid-tread: zero is a code): value = clip(rint(v / LSB), n_lo, n_hi) LSB.
Full scale clips at the end codes, so the largest reading is acc_range - LSB (force_range_N - LSB)
and the smallest -acc_range (0). NaN stays NaN (a broken plant must stay visible); the tip
integrator takes a non-finite reading as 0 m/s^2 (``_tip_velocity``).

Noise: zero-mean Gaussian of the configured rms, added before the ADC, drawn from the seeded
generator of ``frictionrt.rt.common.noise``: four normals per tick, always in the order (acc tip, acc frf) from
one Box-Muller pair, then (strain, cell) from the next, also when an rms is zero, so that the
sequence never depends on the configuration. The generator state is NOT a slot of the float64
state vector: it is its own (4,) uint64 array argument ``rng`` (``frictionrt.rt.common.noise.new_rng(cfg.rt.seed)``),
advanced in place by each step (arbitrary uint64 words are not meaningful floats and some are
NaN payloads, which logging or NaN checks of the state must never see).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from frictionrt.plant.actuator import discretise
from frictionrt.rt.common.config import Config
from frictionrt.rt.common.noise import _check as _check_rng
from frictionrt.rt.common.noise import _normal_pair

SENSOR_SLOTS = ("acc_tip_y", "acc_tip_r", "acc_frf_y", "acc_frf_r", "a_tip_in", "a_frf_in",
                "v_tip", "a_tip_meas_in", "F_strain_y", "F_cell_y", "F_N1_in")
"""State slots: Butterworth output and rate (r = y'/w) of each accelerometer [m/s^2], previous
plant samples a_tip, a_frf [m/s^2], integrator output v_tip [m/s], previous measured tip
acceleration [m/s^2], strain-gauge and force-cell filter outputs of a sampled force [N] and its
previous sample [N] (``_sensors_read``: F_N1 samples, or the bolt's separation force dF_N1)."""

SENSOR_INPUTS = (("a_tip", "m/s^2"), ("a_frf", "m/s^2"), ("F_strain_a", "N"), ("F_cell_a", "N"), ("dF_N1", "N"))
"""Inputs of the loop's form; the alternatives (without dF_N1; a_tip, a_frf, F_N1) are described above."""
SENSOR_OUTPUTS = (("a_tip_meas", "m/s^2"), ("a_frf_meas", "m/s^2"), ("v_tip_meas", "m/s"),
                  ("F_strain", "N"), ("F_cell", "N"))


class SensorParams(NamedTuple):
    """Constant arrays of the sensor step (built by ``build_sensors``).

    Filter coefficients, exact first-order-hold discretisations over dt (module docstring):

        Bw = [ Phi (2 x 2) | G0 | G1 ]      accelerometer Butterworth, state (y, r)   (2 x 4)

        F1 = [ phi  g0  g1 ]  leaky integrator v_tip
             [ phi  g0  g1 ]  strain gauge                                          (3 x 3)
             [ phi  g0  g1 ]  force cell
    """
    Bw: np.ndarray        # (2, 4)
    F1: np.ndarray        # (3, 3)
    acc_sigma: float      # accelerometer noise rms [m/s^2]
    strain_sigma: float   # strain-gauge noise rms [N]
    cell_sigma: float     # force-cell noise rms [N]
    acc_lsb: float        # 2 acc_range / 2^adc_bits [m/s^2]
    acc_inv_lsb: float
    acc_n_lo: float       # -2^(adc_bits - 1)
    acc_n_hi: float       # 2^(adc_bits - 1) - 1
    force_lsb: float      # force_range_N / 2^adc_bits [N]
    force_inv_lsb: float
    force_n_lo: float     # 0
    force_n_hi: float     # 2^adc_bits - 1
    w_c: float            # integrator corner 2 pi velocity_corner_hz [rad/s]


def build_sensors(cfg: Config) -> SensorParams:
    """Constant arrays of ``_sensors_step`` for the configuration (controller step cfg.dt_s)."""
    s = cfg.sensors
    dt = cfg.dt_s
    w = 2.0 * math.pi * s.acc_bandwidth_hz
    Phi, G0, G1 = discretise(np.array([[0.0, w], [-w, -math.sqrt(2.0) * w]]), np.array([0.0, w]), dt)
    Bw = np.ascontiguousarray(np.column_stack([Phi, G0[:, 0], G1[:, 0]]))
    w_c = 2.0 * math.pi * s.velocity_corner_hz
    rows = []
    for A, B in ((-w_c, 1.0),
                 (-2.0 * math.pi * s.strain_bandwidth_hz, 2.0 * math.pi * s.strain_bandwidth_hz),
                 (-2.0 * math.pi * s.cell_bandwidth_hz, 2.0 * math.pi * s.cell_bandwidth_hz)):
        phi, g0, g1 = discretise(np.array([[A]]), np.array([B]), dt)
        rows.append([phi[0, 0], g0[0, 0], g1[0, 0]])
    F1 = np.ascontiguousarray(np.array(rows))
    nb = 2 ** s.adc_bits
    acc_lsb = 2.0 * s.acc_range / nb
    force_lsb = s.force_range_N / nb
    p = SensorParams(
        Bw=Bw, F1=F1, acc_sigma=float(s.acc_noise_rms), strain_sigma=float(s.strain_noise_N),
        cell_sigma=float(s.cell_noise_N),
        acc_lsb=float(acc_lsb), acc_inv_lsb=float(1.0 / acc_lsb), acc_n_lo=float(-(nb // 2)),
        acc_n_hi=float(nb // 2 - 1),
        force_lsb=float(force_lsb), force_inv_lsb=float(1.0 / force_lsb), force_n_lo=0.0,
        force_n_hi=float(nb - 1), w_c=float(w_c))
    for arr in p:
        if isinstance(arr, np.ndarray):
            arr.setflags(write=False)
    return p


def slot_index() -> dict[str, int]:
    """Name -> index in the sensor state vector."""
    return {nm: i for i, nm in enumerate(SENSOR_SLOTS)}


def output_index() -> dict[str, int]:
    """Name -> index in the sensor output vector."""
    return {nm: i for i, (nm, _) in enumerate(SENSOR_OUTPUTS)}


def initial_state(p: SensorParams, a_tip: float = 0.0, a_frf: float = 0.0, F_N1: float = 0.0) -> np.ndarray:
    """Steady state of every filter for constant inputs a_tip, a_frf [m/s^2], F_N1 [N]
    (the integrator at a_tip / w_c)."""
    x = np.zeros(len(SENSOR_SLOTS))
    i = slot_index()
    x[i["acc_tip_y"]] = x[i["a_tip_in"]] = x[i["a_tip_meas_in"]] = a_tip
    x[i["acc_frf_y"]] = x[i["a_frf_in"]] = a_frf
    x[i["v_tip"]] = a_tip / p.w_c
    x[i["F_strain_y"]] = x[i["F_cell_y"]] = x[i["F_N1_in"]] = F_N1
    return x


# --- run time --------------------------------------------------------------------------------

@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _adc(v, inv_lsb, lsb, n_lo, n_hi):
    """ADC reading: clip(rint(v / LSB), n_lo, n_hi) LSB (ties to even; NaN stays NaN). RT-safe."""
    n = np.rint(v * inv_lsb)
    if n > n_hi:
        n = n_hi
    elif n < n_lo:
        n = n_lo
    return n * lsb + 0.0  # + 0.0: no negative zero readings


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy")
def _sensors_step(k, x, u, p, x_next, y, rng):
    """Sensor readings at t_k from the plant/actuator samples at t_k: ``_sensors_read`` (the
    ADC readings) then ``_tip_velocity`` (the controller's integrator). The loop calls the two
    itself, with fault injection between them (``frictionrt.rt.loop.supervisor``). Arguments as
    ``_sensors_read``. RT-safe."""
    _sensors_read(k, x, u, p, x_next, y, rng)
    _tip_velocity(x, p, x_next, y)


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy")
def _tip_velocity(x, p, x_next, y):
    """The leaky integrator of the measured tip acceleration y[0] -> y[2] = v_tip_meas [m/s]
    (slots v_tip, a_tip_meas_in of x_next written). A non-finite reading (a dropout) counts as
    0 m/s^2 (no information; holding the last sample would integrate it over the whole gap), so
    the integrator's state stays finite. RT-safe."""
    u0 = x[7]
    a = y[0] if math.isfinite(y[0]) else 0.0
    v = p.F1[0, 0] * x[6] + p.F1[0, 1] * u0 + p.F1[0, 2] * (a - u0)
    x_next[6] = v
    x_next[7] = a
    y[2] = v


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy")
def _sensors_read(k, x, u, p, x_next, y, rng):
    """The ADC readings at t_k from the plant/actuator samples at t_k (all but v_tip_meas).

    Parameters
    ----------
    k : int64 tick (time-invariant; kept for the uniform step signature)
    x : (11,) state at t_{k-1}, slots ``SENSOR_SLOTS`` (read only)
    u : (5,) a_tip, a_frf [m/s^2] (plant outputs at x = 0.765 m and x = 0.45 m), F_strain_a,
        F_cell_a [N] (the actuator's analog force-sensor outputs of the stack force F_stack) and
        dF_N1 [N] (the plant's bolt force response to the beams' separation, F_N1 - F_stack:
        filtered here on its samples, added: the sensors measure the bolt force F_N1), or
        (4,) without dF_N1 (a bolt that does not see the structure), or
        (3,) a_tip, a_frf, F_N1 [N] (force sensors filtered here on the F_N1 samples)
    p : SensorParams
    x_next : (11,) state at t_k (written; slots v_tip, a_tip_meas_in by ``_tip_velocity``)
    y : (5,) ``SENSOR_OUTPUTS`` (written): a_tip_meas, a_frf_meas [m/s^2], F_strain, F_cell [N];
        y[2] = v_tip_meas [m/s] is ``_tip_velocity``'s
    rng : (4,) uint64 generator state (``frictionrt.rt.common.noise.new_rng``), advanced by four normals

    Each filter: z_k = Phi z_{k-1} + G0 u_{k-1} + G1 (u_k - u_{k-1}) (exact first-order hold);
    readings = ADC(filter output + sigma N(0, 1)).
    The force filter slots F_strain_y, F_cell_y, F_N1_in hold the filtered sampled force and its
    previous sample: F_N1 (length 3), dF_N1 (length 5), or F_strain_a, F_cell_a with F_N1_in kept
    (length 4). The filters are linear, so the 5-input form's readings are the filtered bolt force
    F_N1 = F_stack + dF_N1 (exact for F_stack, first-order hold for the smooth dF_N1).
    RT-safe (no allocation; the only side effect is advancing rng).
    """
    # NamedTuple fields and coefficients into locals
    Bw, F1 = p.Bw, p.F1
    b00, b01, b10, b11 = Bw[0, 0], Bw[0, 1], Bw[1, 0], Bw[1, 1]
    c00, c10, c01, c11 = Bw[0, 2], Bw[1, 2], Bw[0, 3], Bw[1, 3]
    acc_inv, acc_lsb, acc_lo, acc_hi = p.acc_inv_lsb, p.acc_lsb, p.acc_n_lo, p.acc_n_hi
    f_inv, f_lsb, f_lo, f_hi = p.force_inv_lsb, p.force_lsb, p.force_n_lo, p.force_n_hi

    a_tip, a_frf = u[0], u[1]
    # --- accelerometers: Butterworth over [t_{k-1}, t_k], noise, ADC
    u0 = x[4]
    du = a_tip - u0
    yt = b00 * x[0] + b01 * x[1] + c00 * u0 + c01 * du
    rt = b10 * x[0] + b11 * x[1] + c10 * u0 + c11 * du
    u0 = x[5]
    du = a_frf - u0
    yf = b00 * x[2] + b01 * x[3] + c00 * u0 + c01 * du
    rf = b10 * x[2] + b11 * x[3] + c10 * u0 + c11 * du
    n_tip, n_frf = _normal_pair(rng)
    n_strain, n_cell = _normal_pair(rng)
    a_tip_m = _adc(yt + p.acc_sigma * n_tip, acc_inv, acc_lsb, acc_lo, acc_hi)
    a_frf_m = _adc(yf + p.acc_sigma * n_frf, acc_inv, acc_lsb, acc_lo, acc_hi)
    # --- bolt force sensors
    if u.shape[0] == 5:  # the actuator's analog outputs plus the bolt's separation force, filtered here
        F_in = u[4]
        u0 = x[10]
        du = F_in - u0
        ys = F1[1, 0] * x[8] + F1[1, 1] * u0 + F1[1, 2] * du
        yc = F1[2, 0] * x[9] + F1[2, 1] * u0 + F1[2, 2] * du
        Fs = u[2] + ys
        Fc = u[3] + yc
    elif u.shape[0] == 4:  # analog outputs from the actuator's exact integration
        Fs = ys = u[2]
        Fc = yc = u[3]
        F_in = x[10]
    else:  # F_N1 samples, filtered here
        F_in = u[2]
        u0 = x[10]
        du = F_in - u0
        Fs = ys = F1[1, 0] * x[8] + F1[1, 1] * u0 + F1[1, 2] * du
        Fc = yc = F1[2, 0] * x[9] + F1[2, 1] * u0 + F1[2, 2] * du
    F_s_m = _adc(Fs + p.strain_sigma * n_strain, f_inv, f_lsb, f_lo, f_hi)
    F_c_m = _adc(Fc + p.cell_sigma * n_cell, f_inv, f_lsb, f_lo, f_hi)

    x_next[0] = yt
    x_next[1] = rt
    x_next[2] = yf
    x_next[3] = rf
    x_next[4] = a_tip
    x_next[5] = a_frf
    x_next[8] = ys
    x_next[9] = yc
    x_next[10] = F_in
    y[0] = a_tip_m
    y[1] = a_frf_m
    y[3] = F_s_m
    y[4] = F_c_m


def sensors_step(k: int, x: np.ndarray, u: np.ndarray, p: SensorParams, x_next: np.ndarray, y: np.ndarray,
                 rng: np.ndarray) -> None:
    """Checked wrapper of ``_sensors_step`` (call the kernel directly inside loops)."""
    n = len(SENSOR_SLOTS)
    if x.shape != (n,) or x_next.shape != (n,):
        raise ValueError(f"sensor state must have shape ({n},) (slots {SENSOR_SLOTS}), got {x.shape}, "
                         f"{x_next.shape}")
    if u.shape not in ((3,), (4,), (5,)):
        raise ValueError("sensor input must be (a_tip [m/s^2], a_frf [m/s^2], F_strain_a [N], F_cell_a [N]"
                         f"[, dF_N1 [N]]) or (a_tip, a_frf, F_N1 [N]), got shape {u.shape}")
    if y.shape != (len(SENSOR_OUTPUTS),):
        raise ValueError(f"sensor output must have shape ({len(SENSOR_OUTPUTS)},), got {y.shape}")
    for a in (x, u, x_next, y):
        if a.dtype != np.float64 or not a.flags.c_contiguous:
            raise ValueError("sensor arrays must be contiguous float64")
    _check_rng(rng)
    _sensors_step(np.int64(k), x, u, p, x_next, y, rng)


@numba.njit(cache=True, nogil=True)
def _sensors_run(x0, U, p, rng, X, Y):
    """Step the sensors over the input rows U (n, 3, 4 or 5) from x0: X (n + 1, 11), Y (n, 5) filled."""
    X[0] = x0
    for k in range(U.shape[0]):
        _sensors_step(k, X[k], U[k], p, X[k + 1], Y[k], rng)


def run_sensors(p: SensorParams, U: np.ndarray, rng: np.ndarray, x0: np.ndarray | None = None):
    """Offline run over input rows U (n, 5) = (a_tip, a_frf, F_strain_a, F_cell_a, dF_N1), (n, 4)
    without dF_N1, or (n, 3) = (a_tip, a_frf, F_N1), one per tick; rng advanced (x0 default: the
    steady state of the first row, the sampled-force filters at dF_N1 for 5 columns).

    Returns (X (n + 1, 11) states, Y (n, 5) readings)."""
    U = np.ascontiguousarray(U, dtype=np.float64)
    if U.ndim != 2 or U.shape[1] not in (3, 4, 5):
        raise ValueError(f"U must have shape (n, 5) = (a_tip, a_frf, F_strain_a, F_cell_a, dF_N1), (n, 4) without "
                         f"dF_N1 or (n, 3) = (a_tip, a_frf, F_N1), got {U.shape}")
    _check_rng(rng)
    if x0 is None:
        x0 = initial_state(p, U[0, 0], U[0, 1], U[0, 4] if U.shape[1] == 5 else U[0, 2]) if len(U) else \
            np.zeros(len(SENSOR_SLOTS))
    X = np.empty((len(U) + 1, len(SENSOR_SLOTS)))
    Y = np.empty((len(U), len(SENSOR_OUTPUTS)))
    _sensors_run(np.ascontiguousarray(x0, dtype=np.float64), U, p, rng, X, Y)
    return X, Y
