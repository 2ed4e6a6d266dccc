"""Run-time supervisor and fault injection (docs/reliability.md): the fail-safe stage of the
controller.

Every tick, after the estimator and the law and before the force tracking
(``frictionrt.rt.loop.tick._controller_tick``), ``_supervise`` checks, in this order (the first failing check
gives the tick's ``fault_code``):

    1 sensor_nonfinite     a reading (a_tip_meas, a_frf_meas, F_strain, F_cell) is NaN or Inf
    2 sensor_range         a reading at an ADC end code: a <= -acc_range or a >= acc_range - LSB,
                           F <= 0 or F >= force_range_N - LSB (the ADC clipped)
    3 sensor_stuck         a reading unchanged for stuck_window_s while its partner (the other
                           accelerometer / force sensor) changed in that window
    4 force_disagree       |F_strain - F_cell| > force_disagree_N for > force_disagree_s (the two
                           sensors of the same bolt force disagree: a gain or bias fault)
    5 observer_divergence  |innovation| > innovation_bound_m_s, ||z_k+1|k||_2 > state_bound, or a
                           non-finite estimate (either estimator)
    6 command_nonfinite    the law's F_set (or, after the tracking, V_cmd) is not finite
    7 tracking_error       |F_set_filtered - F_meas| > tracking_error_N for > tracking_error_s
    8 amp_saturation       saturated != 0 with saturated (F_set_filtered - F_meas) >
                           saturation_error_N for > saturation_s (the amplifier at a rail cannot
                           deliver the force asked)
    9 overrun_burst        paced: overrun_count overrunning ticks within overrun_window_s

The tracking checks use the previous tick's error and saturation (``_supervise_after`` records
them), the overrun check the previous tick's overrun (the loop writes S_OVERRAN at the end of a
tick; the replay from the logged tick_ns + late_ns > period). On a fault the tick's F_set is
replaced by F_min before the prefilter, feedforward and PID, the PID integrator is reset and
held at 0 while passive, and the fault is latched (code, tick); recovery: ``latch`` (passive
until the run ends) or ``auto`` (active again after clean_window_s of ticks without a failing
check). Always, whatever ``enable``: a non-finite reading is replaced for the controller by the
sensor's last finite reading (``_sanitise``), so a NaN never reaches F_set, V_cmd or the plant.

State: one flat float64 vector (``SUPERVISOR_SLOTS``; counters and ticks are exact integers in
float64), carried between ticks and runs (``LoopState.sv``). Outputs ``SUPERVISOR_OUTPUTS``:
fault_code (this tick's), fault_latched (the latched code, 0 when active), passive (0/1).

Fault injection: a schedule ``F`` (n, 5) float64 rows (kind, target, k_start, k_end, value),
active for k_start <= k < k_end (``frictionrt.rt.loop.faults`` builds it from ``--fault`` strings); applied by
the loop at the sensor stage (``_inject_sensors``), the observer's input (``_inject_observer``),
the actuator's input (``_inject_actuator``) and as a busy delay (``_stall_ns``). No callbacks:
the kernels read the array.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from frictionrt.plant.sensors import _adc

FAULT_CODES = ("none", "sensor_nonfinite", "sensor_range", "sensor_stuck", "force_disagree", "observer_divergence",
               "command_nonfinite", "tracking_error", "amp_saturation", "overrun_burst")
(NONE, SENSOR_NONFINITE, SENSOR_RANGE, SENSOR_STUCK, FORCE_DISAGREE, OBSERVER_DIVERGENCE, COMMAND_NONFINITE,
 TRACKING_ERROR, AMP_SATURATION, OVERRUN_BURST) = range(len(FAULT_CODES))
SUPERVISOR_OUTPUTS = (("fault_code", "-"), ("fault_latched", "-"), ("passive", "-"))

FAULT_KINDS = ("sensor_dropout", "sensor_stuck", "sensor_gain", "sensor_bias", "actuator_loss",
               "force_saturation", "observer_mismatch", "cpu_stall")
(K_DROPOUT, K_STUCK, K_GAIN, K_BIAS, K_ACT_LOSS, K_FORCE_SAT, K_OBS_MISMATCH, K_CPU_STALL) = range(len(FAULT_KINDS))
F_KIND, F_TARGET, F_START, F_END, F_VALUE = range(5)

CHECKED = (0, 1, 3, 4)  # readings checked: a_tip_meas, a_frf_meas, F_strain, F_cell (v_tip_meas is derived)
PARTNER = (1, 0, 4, 3)  # the other accelerometer / force sensor
N_READ = 5              # len(SENSOR_OUTPUTS)
RING = 64               # largest overrun_count
SUPERVISOR_SLOTS = (("code", "latched", "passive", "trip_tick", "clean", "err_prev", "sat_prev", "err_n", "sat_n",
                     "overran", "ovr_n", "ovr_head", "dis_n")
                    + tuple(f"last_{i}" for i in range(N_READ)) + tuple(f"same_{i}" for i in range(N_READ))
                    + tuple(f"good_{i}" for i in range(N_READ)) + tuple(f"ring_{i}" for i in range(RING)))
(S_CODE, S_LATCHED, S_PASSIVE, S_TRIP_TICK, S_CLEAN, S_ERR, S_SAT, S_ERR_N, S_SAT_N, S_OVERRAN, S_OVR_N,
 S_OVR_HEAD, S_DIS_N) = range(13)
S_LAST, S_SAME, S_GOOD, S_RING = 13, 13 + N_READ, 13 + 2 * N_READ, 13 + 3 * N_READ


class SupervisorParams(NamedTuple):
    """Constants of the supervisor (``build_supervisor``); durations in ticks."""
    enable: bool
    auto: bool            # recovery "auto"
    observe: bool         # the observer runs (innovation and state checks)
    acc_lo: float         # -acc_range [m/s^2]
    acc_hi: float         # acc_range - LSB [m/s^2]
    force_hi: float       # force_range_N - LSB [N] (low end: 0 N)
    stuck_ticks: int
    dis_N: float          # [N]
    dis_ticks: int
    innovation: float     # [m/s]
    state: float          # [m kg^0.5 / s]
    err_N: float          # [N]
    err_ticks: int
    sat_N: float          # [N]
    sat_ticks: int
    ovr_count: int
    ovr_ticks: int
    clean_ticks: int
    F_min: float          # [N]
    V_passive: float      # sat((F_min - F0) / c_v) [V]: the command if V_cmd were not finite


def _ticks(t_s: float, dt: float) -> int:
    return max(1, int(round(t_s / dt)))


def build_supervisor(cfg, observe: bool) -> SupervisorParams:
    """Supervisor constants from ``cfg.supervisor``, the ADC ranges and the force range."""
    s, dt = cfg.supervisor, cfg.dt_s
    nb = 2 ** cfg.sensors.adc_bits
    a, t = cfg.actuator, cfg.tracking
    v_pass = min(max((t.F_min_N - a.F0_N) / a.c_v, a.V_min), a.V_max)
    return SupervisorParams(
        enable=bool(s.enable), auto=s.recovery == "auto", observe=bool(observe),
        acc_lo=-cfg.sensors.acc_range, acc_hi=cfg.sensors.acc_range - 2.0 * cfg.sensors.acc_range / nb,
        force_hi=cfg.sensors.force_range_N * (1.0 - 1.0 / nb),
        stuck_ticks=_ticks(s.stuck_window_s, dt), dis_N=float(s.force_disagree_N),
        dis_ticks=_ticks(s.force_disagree_s, dt), innovation=float(s.innovation_bound_m_s), state=float(s.state_bound),
        err_N=float(s.tracking_error_N), err_ticks=_ticks(s.tracking_error_s, dt), sat_N=float(s.saturation_error_N),
        sat_ticks=_ticks(s.saturation_s, dt), ovr_count=int(s.overrun_count), ovr_ticks=_ticks(s.overrun_window_s, dt),
        clean_ticks=_ticks(s.clean_window_s, dt), F_min=float(t.F_min_N), V_passive=float(v_pass))


def initial_state(readings: np.ndarray) -> np.ndarray:
    """Supervisor state at rest: active, counters 0, the last readings (and last finite ones)
    those of the rest state ``readings`` (SENSOR_OUTPUTS order)."""
    s = np.zeros(len(SUPERVISOR_SLOTS))
    s[S_LAST:S_LAST + N_READ] = readings
    s[S_GOOD:S_GOOD + N_READ] = readings
    return s


def no_faults() -> np.ndarray:
    """The empty fault schedule."""
    return np.zeros((0, 5))


# --- run time: the supervisor ------------------------------------------------------------------

@numba.njit(cache=True, nogil=True, _nrt=False)
def _sanitise(s, ys, yc):
    """yc[i] = ys[i] if finite, else the last finite reading of sensor i (kept in s). RT-safe."""
    for i in range(N_READ):
        v = ys[i]
        if math.isfinite(v):
            s[S_GOOD + i] = v
        yc[i] = s[S_GOOD + i]


@numba.njit(cache=True, nogil=True, _nrt=False)
def _check(k, s, ys, ye, z, F_set, p):
    """The first failing check's code (module docstring), counters in s advanced. RT-safe."""
    code = NONE
    # --- sensors: non-finite, range, stuck (per reading; partner = the other one of the pair)
    for j in range(4):
        i = CHECKED[j]
        v = ys[i]
        if v == s[S_LAST + i]:
            s[S_SAME + i] += 1.0
        else:
            s[S_SAME + i] = 0.0
        s[S_LAST + i] = v
    for j in range(4):
        i = CHECKED[j]
        v = ys[i]
        if not math.isfinite(v):
            c = SENSOR_NONFINITE
        elif (i < 2 and (v <= p.acc_lo or v >= p.acc_hi)) or (i >= 2 and (v <= 0.0 or v >= p.force_hi)):
            c = SENSOR_RANGE
        elif s[S_SAME + i] >= p.stuck_ticks and s[S_SAME + PARTNER[j]] < p.stuck_ticks:
            c = SENSOR_STUCK
        else:
            c = NONE
        if c != NONE and (code == NONE or c < code):
            code = c
    s[S_DIS_N] = s[S_DIS_N] + 1.0 if abs(ys[3] - ys[4]) > p.dis_N else 0.0
    if code == NONE and s[S_DIS_N] > p.dis_ticks:
        code = FORCE_DISAGREE
    # --- estimator
    if code == NONE:
        bad = not (math.isfinite(ye[0]) and math.isfinite(ye[1]))
        if p.observe:
            n2 = 0.0
            for i in range(z.shape[0]):
                n2 += z[i] * z[i]
            bad = bad or not (abs(ye[2]) <= p.innovation and n2 <= p.state * p.state)
        if bad:
            code = OBSERVER_DIVERGENCE
        elif not math.isfinite(F_set):
            code = COMMAND_NONFINITE
    # --- force tracking of the previous tick
    e = s[S_ERR]
    sat = s[S_SAT]
    s[S_ERR_N] = s[S_ERR_N] + 1.0 if abs(e) > p.err_N else 0.0
    s[S_SAT_N] = s[S_SAT_N] + 1.0 if sat != 0.0 and sat * e > p.sat_N else 0.0
    if code == NONE:
        if s[S_ERR_N] > p.err_ticks:
            code = TRACKING_ERROR
        elif s[S_SAT_N] > p.sat_ticks:
            code = AMP_SATURATION
    # --- overruns: ring of the last ovr_count overrunning ticks
    if s[S_OVERRAN] != 0.0:
        h = int(s[S_OVR_HEAD])
        s[S_RING + h] = k - 1  # the tick that overran
        h = (h + 1) % p.ovr_count
        s[S_OVR_HEAD] = h
        s[S_OVR_N] = min(s[S_OVR_N] + 1.0, p.ovr_count)
        if code == NONE and s[S_OVR_N] >= p.ovr_count and (k - 1) - s[S_RING + h] < p.ovr_ticks:
            code = OVERRUN_BURST
    return code


@numba.njit(cache=True, nogil=True, _nrt=False)
def _latch(k, s, code, p):
    """Latch a fault (go passive) or count clean ticks towards auto recovery. RT-safe."""
    s[S_CODE] = code
    if not p.enable:
        return
    if s[S_PASSIVE] == 0.0:
        if code != NONE:
            s[S_PASSIVE] = 1.0
            s[S_LATCHED] = code
            s[S_TRIP_TICK] = k
            s[S_CLEAN] = 0.0
    elif p.auto:
        s[S_CLEAN] = s[S_CLEAN] + 1.0 if code == NONE else 0.0
        if s[S_CLEAN] >= p.clean_ticks:
            s[S_PASSIVE] = 0.0
            s[S_LATCHED] = 0.0
            s[S_CLEAN] = 0.0


@numba.njit(cache=True, nogil=True, _nrt=False)
def _supervise(k, s, ys, ye, z, F_set, p):
    """Tick k's checks and latch; returns the setpoint for the force tracking: F_min when
    passive (or when F_set is not finite), else the law's F_set [N]. RT-safe."""
    _latch(k, s, _check(k, s, ys, ye, z, F_set, p), p)
    if s[S_PASSIVE] != 0.0 or not math.isfinite(F_set):
        return p.F_min
    return F_set


@numba.njit(cache=True, nogil=True, _nrt=False)
def _supervise_after(k, s, e, yf, p, y):
    """After the force tracking: record the error e [N] and saturation for the next tick's
    checks, replace a non-finite V_cmd by V_passive (latching command_nonfinite), fill the
    outputs y = (fault_code, fault_latched, passive). RT-safe."""
    s[S_ERR] = e if math.isfinite(e) else 0.0
    s[S_SAT] = yf[1]
    if not math.isfinite(yf[0]):
        yf[0] = p.V_passive
        if s[S_CODE] == NONE:
            _latch(k, s, COMMAND_NONFINITE, p)
    y[0] = s[S_CODE]
    y[1] = s[S_LATCHED]
    y[2] = s[S_PASSIVE]


# --- run time: fault injection -----------------------------------------------------------------

@numba.njit(cache=True, nogil=True, _nrt=False)
def _inject_sensors(k, F, ys, prev, sp):
    """Sensor faults active at tick k on the ADC readings ys (SENSOR_OUTPUTS order, before the
    tip integrator): dropout NaN; stuck: the previous tick's reading prev; gain, bias: the
    reading times / plus value, through the ADC again (clipped, quantised). RT-safe."""
    for r in range(F.shape[0]):
        kind = int(F[r, F_KIND])
        if kind > K_BIAS or not (F[r, F_START] <= k < F[r, F_END]):
            continue
        i = int(F[r, F_TARGET])
        v = F[r, F_VALUE]
        if kind == K_DROPOUT:
            ys[i] = np.nan
        elif kind == K_STUCK:
            ys[i] = prev[i]
        else:
            x = ys[i] * v if kind == K_GAIN else ys[i] + v
            if i < 2:
                ys[i] = _adc(x, sp.acc_inv_lsb, sp.acc_lsb, sp.acc_n_lo, sp.acc_n_hi)
            else:
                ys[i] = _adc(x, sp.force_inv_lsb, sp.force_lsb, sp.force_n_lo, sp.force_n_hi)


@numba.njit(cache=True, nogil=True, _nrt=False)
def _inject_observer(k, F, ue):
    """observer_mismatch at tick k: the observer's measured tip velocity ue[0] scaled by value
    (the model's sign or gain of the tip mode shapes no longer that of the structure). RT-safe."""
    for r in range(F.shape[0]):
        if int(F[r, F_KIND]) == K_OBS_MISMATCH and F[r, F_START] <= k < F[r, F_END]:
            ue[0] *= F[r, F_VALUE]


@numba.njit(cache=True, nogil=True, _nrt=False)
def _inject_actuator(k, F, V_cmd):
    """The amplifier input at tick k [V]: 0 V while actuator_loss (amplifier off), at most value
    [V] while force_saturation (the stack's force capped), else V_cmd. RT-safe."""
    V = V_cmd
    for r in range(F.shape[0]):
        kind = int(F[r, F_KIND])
        if F[r, F_START] <= k < F[r, F_END]:
            if kind == K_ACT_LOSS:
                V = 0.0
            elif kind == K_FORCE_SAT:
                V = min(V, F[r, F_VALUE])
    return V


@numba.njit(cache=True, nogil=True, _nrt=False)
def _stall_ns(k, F):
    """The busy delay [ns] cpu_stall adds to tick k. RT-safe."""
    d = 0
    for r in range(F.shape[0]):
        if int(F[r, F_KIND]) == K_CPU_STALL and F[r, F_START] <= k < F[r, F_END]:
            d += int(F[r, F_VALUE])
    return d
