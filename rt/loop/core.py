"""The hard fixed-step loop (SPEC section 7): every tick of a run inside one compiled function.

One tick k, t_k = k dt (int64 tick, never accumulated time), in this fixed order:

    1 sensors    mean accelerations of the plant over the last tick (plant outputs abar_*) and the
                 bolt-force sensors' analog outputs of the stack force
                 (integrated inside the actuator, exact between samples) plus the bolt's response
                 to the beams' separation (plant output dF_N1) -> ADC readings of the bolt force
    2 estimator  oracle: the plant's true u_rel, v_rel at t_k, band-limited (observer.oracle),
                 or observer: the Kalman-designed nonlinear observer on the measured tip
                 velocity and the force cell's F_N (observer.step)
    3 law        F* (passive, hysteresis-optimal with RT1, Lyapunov)
    3s supervisor checks the tick (rt.loop.supervisor); on a fault F* := F_min in this tick
    4 tracking   V_cmd = feedforward + PID on the law's force sensor
    5 actuator   DAC -> 30 kHz low-pass -> amplifier -> piezo stack over [t_k, t_k+1]
    5s shaker    (with shaker.armature_mass_kg > 0) the excitation generator's drive through the
                 armature and stinger (plant.shaker): F_exc = the stinger force, mean over the tick,
                 from the plant's excitation-point motion at t_k; otherwise F_exc = drive
    6 plant      over [t_k, t_k+1]: F_exc(t_k) held, the stack force F_stack = mean of its values
                 at t_k, t_k+1 as the adaptive bolt's preload; the bolts' springs act implicitly
                 on the separation (docs/plant.md 1.4), so F_N1 = F_stack + k (g - g_ref)
    7 log        every signal of the tick into row k of the preallocated log (with a log writer: a
                 ring of R rows, row (k - k_start) mod R; ``run``, rt/log/writer.py)

Two ways to run, one function: as fast as possible (offline, deterministic), or paced to the
wall clock: absolute deadlines next += period, busy-wait on CLOCK_MONOTONIC, overruns counted
and skipped by whole periods, each tick's execution time and lateness logged. Ticks run in
chunks so that Python can show progress between them; the deadline carries over.

Stages 2-4 with the supervisor are one function, ``_controller_tick``, which the replay
(``rt.loop.replay``) runs on logged readings. Injected faults (``rt.loop.faults``) act on the readings
after the ADC (stage 1), the observer's input, the amplifier's input (stage 5) and as a busy
delay (cpu_stall).
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numba
import numpy as np

from plant.actuator import ACTUATOR_OUTPUTS, ActuatorParams, _actuator_step, build_actuator
from plant.actuator import initial_state as actuator_initial_state
from plant.actuator import output_index as actuator_output_index
from plant.model import PlantModel, build_plant
from observer.accuracy import band_limited_truth, nrmse
from observer.kalman import ObserverParams, design_observer
from observer.oracle import ORACLE_OUTPUTS, build_oracle
from observer.step import OBSERVER_OUTPUTS, _observer_step
from tracking.lowpass import BiquadParams, _biquad_step, rest_state
from plant.newmark import _plant_step
from rt.common.clock import _now_ns
from rt.common.config import Config
from rt.common.noise import new_rng
from plant.sensors import SENSOR_OUTPUTS, SensorParams, _sensors_read, _tip_velocity, build_sensors
from plant.sensors import initial_state as sensors_initial_state
from plant.shaker import ShakerParams, _shaker_step, build_shaker, check_shaker
from plant.sensors import output_index as sensor_output_index
from tracking.force_tracking import (FORCE_TRACKING_OUTPUTS, SENSOR_OF_LAW, ForceTrackingDesign,
                                     _force_tracking_step, design_force_tracking)
from tracking.force_tracking import initial_state as tracking_initial_state
from tracking.laws import LAWS_OUTPUTS, LAWS_SLOTS, _laws_step, build_laws
from tracking.prefilter import PREFILTER_OUTPUTS, build_prefilter
from rt.loop.supervisor import (F_END, F_KIND, F_START, F_TARGET, K_DROPOUT, S_OVERRAN, S_PASSIVE, SUPERVISOR_OUTPUTS,
                           SupervisorParams, _inject_actuator, _inject_observer,
                           _inject_sensors, _stall_ns, _sanitise, _supervise, _supervise_after, build_supervisor,
                           no_faults)
from rt.loop.supervisor import initial_state as supervisor_initial_state

COMPONENTS = ("sensors", "estimator", "law", "supervisor", "tracking", "actuator", "plant", "log")
ESTIMATORS = ("oracle", "observer")
# state shared by the chunks of one run and the Python threads watching it (int64): next deadline
# [ns], overruns, ticks run, stop request (set by the watcher: the loop ends after its tick),
# written: ticks below this absolute tick are out of the ring (set by the writer; offline the loop
# waits for it before overwriting a row)
CLK_DEADLINE, CLK_OVERRUNS, CLK_TICKS, CLK_STOP, CLK_WRITTEN = 0, 1, 2, 3, 4
CLK_SIZE = 5
NO_WAIT = 2**62  # CLK_WRITTEN when no writer drains the log: the loop never waits
COL_V_TIP, COL_F_CELL = sensor_output_index()["v_tip_meas"], sensor_output_index()["F_cell"]  # the observer's inputs


@dataclass(frozen=True)
class Loop:
    """Everything a run needs, built once at design time from the configuration."""
    cfg: Config
    law: str
    plant: PlantModel
    actuator: ActuatorParams
    sensors: SensorParams
    oracle: BiquadParams
    observer: ObserverParams  # the designed observer, or empty arrays when the oracle runs
    prefilter: BiquadParams
    law_params: object
    design: ForceTrackingDesign
    force_sensor: str
    signals: tuple[tuple[str, str, str], ...]   # (name, unit, owner) per log column
    estimator: str = "oracle"                   # one of ESTIMATORS
    supervisor: SupervisorParams | None = None  # built by build_loop
    shaker: ShakerParams | None = None          # built by build_loop (P = 0: ideal force source)

    def column(self, name: str) -> int:
        return next(i for i, (n, _, _) in enumerate(self.signals) if n == name)


def loop_signals(plant: PlantModel) -> tuple[tuple[str, str, str], ...]:
    """Log columns in order: (name, unit, owning package)."""
    sig = [("F_exc", "N", "rt")]
    sig += [(n, u, "sensors") for n, u in SENSOR_OUTPUTS]
    sig += [(n, u, "observer") for n, u in OBSERVER_OUTPUTS]  # the oracle fills the first two
    sig += [(n, u, "tracking") for n, u in LAWS_OUTPUTS]
    sig += [(n, u, "tracking") for n, u in PREFILTER_OUTPUTS]
    sig += [(n, u, "tracking") for n, u in FORCE_TRACKING_OUTPUTS]
    sig += [(n, u, "rt") for n, u in SUPERVISOR_OUTPUTS]
    sig += [(n, u, "actuator") for n, u in ACTUATOR_OUTPUTS]
    sig += [(n, u, "plant") for n, u in plant.output_labels()]
    sig += [("tick_ns", "ns", "rt"), ("late_ns", "ns", "rt")]
    return tuple(sig)


def build_loop(cfg: Config, law: str | None = None, estimator: str = "oracle",
               observer_cfg: Config | None = None) -> Loop:
    """Design time: plant, actuator, sensors, estimator, law and the force-tracking design for
    its sensor. The observer is designed from ``observer_cfg`` if given (a model that differs
    from the plant: robustness studies), else from cfg.

    Raises ValueError (from the design) if the force-tracking loop would be unstable, or for an
    unknown estimator."""
    law = cfg.tracking.law if law is None else law
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator {estimator!r}: expected one of {', '.join(ESTIMATORS)}")
    plant = build_plant(cfg)
    sensor = SENSOR_OF_LAW[law]
    design = design_force_tracking(cfg, sensor)
    if estimator == "observer":
        observer = (design_observer(cfg, plant) if observer_cfg is None else design_observer(observer_cfg)).params
    else:
        observer = _no_observer()
    check_shaker(cfg, plant)
    return Loop(cfg, law, plant, build_actuator(cfg), build_sensors(cfg), build_oracle(cfg), observer,
                build_prefilter(cfg), build_laws(cfg, law), design, sensor, loop_signals(plant), estimator,
                build_supervisor(cfg, estimator == "observer"), build_shaker(cfg))


def _no_observer() -> ObserverParams:
    """Observer parameters of size 0 (same types): the compiled loop's observer branch is not
    taken when the oracle runs."""
    e = np.zeros(0)
    return ObserverParams(A_d=np.zeros((0, 0)), B_dT=e, M=e, L=e, C_meas=e, C_u=e, C_v=e, CvA=e, beta=-1.0,
                          D_u=0.0, mu=0.0, alpha=1.0)


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _put(log, row, c, y):
    """log[row, c:c + len(y)] = y; returns the next column. RT-safe."""
    for i in range(y.shape[0]):
        log[row, c + i] = y[i]
    return c + y.shape[0]


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _copy(src, dst):
    """dst[:] = src (a component's next state becomes its state). RT-safe."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _actuate(k, F_exc, V_cmd, xa, xa_n, ya, ua, act_p, xp, xp_n, yp, up, plant_p, plant_wk, timing, ts):
    """Stages 5 and 6 of tick k: the actuator over [t_k, t_k+1] on the command V_cmd [V], then
    the plant over [t_k, t_k+1] with F_exc [N] held and the stack force (F_stack(t_k) +
    F_stack(t_k+1)) / 2 as the adaptive bolt's preload (ya[0] on entry is F_stack(t_k)). ya, yp receive the outputs at t_k+1; the next states go to
    xa_n, xp_n. The loop and the plant replay (``rt.loop.replay_plant``) both call this. Returns
    (the plant's Newton iterations, -1 on a failed solve; the clock [ns] after the actuator
    if timing, else 0). RT-safe."""
    F_start = ya[0]
    ua[0] = V_cmd
    _actuator_step(k, xa, ua, act_p, xa_n, ya)
    t5 = _now_ns(ts) if timing else 0
    up[0] = F_exc
    up[1] = 0.5 * (F_start + ya[0])
    return _plant_step(k, xp, up, plant_p, xp_n, yp, plant_wk), t5


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _controller_tick(k, ys, yc, u_rel, v_rel, force_col, observe, faults, timing, ts, est, law, sup, trk):
    """Stages 2-4 of tick k with the supervisor, on the readings ys (``SENSOR_OUTPUTS``) and the
    plant's u_rel [m], v_rel [m/s] (read by the oracle only): the loop and the replay both run
    this. The stages' arrays come in four tuples (a call of more than ~30 arguments cannot be
    inlined): est = (xo, xo_n, yo, uo, oracle_p, xe, xe_n, ye, ue, obs_p), law = (xl, xl_n, yl,
    ul, law_p), sup = (sv, ysv, sv_p), trk = (xq, xq_n, yq, uq, pre_p, xf, xf_n, yf, uf, ft_p). yc receives the readings the controller uses (non-finite ones replaced by the last
    finite, ``rt.loop.supervisor._sanitise``); ye, yl, yq, yf, ysv the stages' outputs; next states
    into x*_n; the supervisor state sv is advanced in place. Returns the clock [ns] after the
    estimator, the law, the supervisor and the tracking if timing, else zeros. RT-safe."""
    xo, xo_n, yo, uo, oracle_p, xe, xe_n, ye, ue, obs_p = est
    xl, xl_n, yl, ul, law_p = law
    sv, ysv, sv_p = sup
    xq, xq_n, yq, uq, pre_p, xf, xf_n, yf, uf, ft_p = trk
    # 2 estimator (oracle: the plant's u_rel, v_rel band-limited)
    _sanitise(sv, ys, yc)
    if observe:
        ue[0] = yc[COL_V_TIP]
        ue[1] = yc[COL_F_CELL]
        _inject_observer(k, faults, ue)
        _observer_step(k, xe, ue, obs_p, xe_n, ye)
    else:
        uo[0] = u_rel
        uo[1] = v_rel
        _biquad_step(k, xo, uo, oracle_p, xo_n, yo)
        ye[0] = yo[0]
        ye[1] = yo[1]
        ye[2] = 0.0
        ye[3] = 0.0
    ul[0] = ye[0]
    ul[1] = ye[1]
    t2 = _now_ns(ts) if timing else 0
    # 3 law
    _laws_step(k, xl, ul, law_p, xl_n, yl)
    t3 = _now_ns(ts) if timing else 0
    # 3s supervisor: the setpoint the tracking gets (F_min when passive)
    F_set = _supervise(k, sv, ys, ye, xe_n, yl[0], sv_p)
    passive = sv[S_PASSIVE] != 0.0
    t3s = _now_ns(ts) if timing else 0
    # 4 force tracking on the law's sensor, setpoint through the prefilter; passive: the PID's
    # integral reset and held at 0 (no windup against a broken actuator or sensor)
    uq[0] = F_set
    _biquad_step(k, xq, uq, pre_p, xq_n, yq)
    uf[0] = yq[0]
    uf[1] = yc[force_col]
    if passive:
        xf[0] = 0.0
    _force_tracking_step(k, xf, uf, ft_p, xf_n, yf)
    if passive:
        xf_n[0] = 0.0
    elif law_p.hold_voltage:  # the passive law holds the stack at the feedforward voltage of F*
        yf[0] = min(max((yq[0] - ft_p.F0) * ft_p.inv_c_v, ft_p.V_min), ft_p.V_max)
        yf[1] = 0.0
        xf_n[0] = 0.0
    # a held stack does not track: no tracking error for the supervisor's check
    _supervise_after(k, sv, 0.0 if (law_p.hold_voltage and not passive) else yq[0] - uf[1], yf, sv_p, ysv)
    t4 = _now_ns(ts) if timing else 0
    return t2, t3, t3s, t4


@numba.njit(cache=True, nogil=True, _nrt=False)  # no allocation, no reference counting
def _run_ticks(k0, k1, dt, exc_amp, exc_omega, force_col, timing, paced, period_ns, clk, ts,
               xs, xs_n, ys, ys_prev, yc, us, sens_p, rng,
               observe, xo, xo_n, yo, uo, oracle_p, xe, xe_n, ye, ue, obs_p,
               xl, xl_n, yl, ul, law_p,
               sv, ysv, sv_p, faults,
               xq, xq_n, yq, uq, pre_p,
               xf, xf_n, yf, uf, ft_p,
               xa, xa_n, ya, ua, act_p,
               xp, xp_n, yp, up, plant_p, plant_wk,
               shake, xsh, xsh_n, ush, ysh, sh_p,
               col_urel, col_vrel, col_a_tip, col_a_frf, col_strain, col_cell, col_dF, col_w_exc, col_v_exc,
               log, comp_ns):
    """Run ticks k0 <= k < k1 (see the module docstring); states are advanced in place.

    observe selects the estimator: False the oracle (states xo), True the observer (states xe;
    inputs: the measured tip velocity and force-cell reading). sv, sv_p: the supervisor's state
    and constants; faults: the fault schedule (``rt.loop.supervisor``, (0, 5) for none). shake: the
    shaker stage runs (states xsh; inputs the drive and the plant's w, w' at the excitation point,
    columns col_w_exc, col_v_exc of yp); False: F_exc = drive (ideal source).
    log[(k - k0) mod len(log)] receives the tick's signals (``loop_signals`` order): a log of
    k1 - k0 rows is filled in order, a shorter one is a ring (``run``); comp_ns the same row's
    per-component times [ns] if timing; ts is the clock's (2,) int64 scratch. Offline (not
    paced) a ring row is never overwritten before the writer has taken it: before tick k the
    loop spins (nogil) while k - clk[CLK_WRITTEN] >= len(log) (``NO_WAIT`` without a writer),
    and ends early on a stop request. Returns the number of failed plant solves.
    """
    failed = 0
    est = (xo, xo_n, yo, uo, oracle_p, xe, xe_n, ye, ue, obs_p)
    law = (xl, xl_n, yl, ul, law_p)
    sup = (sv, ysv, sv_p)
    trk = (xq, xq_n, yq, uq, pre_p, xf, xf_n, yf, uf, ft_p)
    for k in range(k0, k1):
        if clk[CLK_STOP]:
            break
        row = (k - k0) % log.shape[0]
        if not paced:  # the ring's row of tick k - len(log) must be out (the clock call re-reads clk)
            while k - clk[CLK_WRITTEN] >= log.shape[0] and not clk[CLK_STOP] and _now_ns(ts) > 0:
                pass
            if clk[CLK_STOP]:
                break
        if paced:
            while _now_ns(ts) < clk[CLK_DEADLINE]:
                pass
        t_start = _now_ns(ts)
        late = t_start - clk[CLK_DEADLINE] if paced else 0
        # 1 sensors: plant accelerations and the force sensors' analog outputs at t_k; injected
        # faults act on the ADC readings, before the controller's tip integrator
        us[0] = yp[col_a_tip]
        us[1] = yp[col_a_frf]
        us[2] = ya[col_strain]
        us[3] = ya[col_cell]
        us[4] = yp[col_dF]   # the bolt's response to the beams' separation: the sensors read F_N1
        _copy(ys, ys_prev)
        _sensors_read(k, xs, us, sens_p, xs_n, ys, rng)
        _inject_sensors(k, faults, ys, ys_prev, sens_p)
        _tip_velocity(xs, sens_p, xs_n, ys)
        stall = _stall_ns(k, faults)
        if stall > 0:
            t_stall = _now_ns(ts) + stall
            while _now_ns(ts) < t_stall:
                pass
        t1 = _now_ns(ts) if timing else 0
        # 2 estimator, 3 law, 3s supervisor, 4 force tracking
        t2, t3, t3s, t4 = _controller_tick(k, ys, yc, yp[col_urel], yp[col_vrel], force_col, observe, faults,
                                           timing, ts, est, law, sup, trk)
        # 5 actuator (faults act on its input) and 6 plant over the tick
        F_exc = exc_amp * math.sin(exc_omega * (k * dt))   # the drive (an ideal source's force)
        if shake:  # 5s: the force the structure gets through the stinger (its time counts as the actuator's)
            ush[0] = F_exc
            ush[1] = yp[col_w_exc]
            ush[2] = yp[col_v_exc]
            _shaker_step(k, xsh, ush, sh_p, xsh_n, ysh)
            F_exc = ysh[0]
        iters, t5 = _actuate(k, F_exc, _inject_actuator(k, faults, yf[0]), xa, xa_n, ya, ua, act_p,
                             xp, xp_n, yp, up, plant_p, plant_wk, timing, ts)
        if iters < 0:
            failed += 1
        t6 = _now_ns(ts) if timing else 0
        # 7 log and advance the states
        log[row, 0] = F_exc
        c = _put(log, row, 1, ys)
        c = _put(log, row, c, ye)
        c = _put(log, row, c, yl)
        c = _put(log, row, c, yq)
        c = _put(log, row, c, yf)
        c = _put(log, row, c, ysv)
        c = _put(log, row, c, ya)
        c = _put(log, row, c, yp)
        _copy(xs_n, xs)
        if observe:
            _copy(xe_n, xe)
        else:
            _copy(xo_n, xo)
        _copy(xl_n, xl)
        _copy(xq_n, xq)
        _copy(xf_n, xf)
        _copy(xa_n, xa)
        _copy(xp_n, xp)
        if shake:
            _copy(xsh_n, xsh)
        t_end = _now_ns(ts)
        log[row, c] = t_end - t_start
        log[row, c + 1] = late
        if timing:
            comp_ns[row, 0] = t1 - t_start
            comp_ns[row, 1] = t2 - t1
            comp_ns[row, 2] = t3 - t2
            comp_ns[row, 3] = t3s - t3
            comp_ns[row, 4] = t4 - t3s
            comp_ns[row, 5] = t5 - t4
            comp_ns[row, 6] = t6 - t5
            comp_ns[row, 7] = t_end - t6
        clk[CLK_TICKS] += 1
        sv[S_OVERRAN] = 0.0
        if paced:
            clk[CLK_DEADLINE] += period_ns
            if t_end > clk[CLK_DEADLINE]:  # overrun: skip ahead by whole periods
                missed = (t_end - clk[CLK_DEADLINE]) // period_ns + 1
                clk[CLK_OVERRUNS] += missed
                clk[CLK_DEADLINE] += missed * period_ns
                sv[S_OVERRAN] = 1.0  # the supervisor's overrun check reads it next tick
    return failed


@dataclass
class LoopState:
    """Every state of the loop between two ticks: each component's state slots x*, the outputs
    of the previous tick that the next one reads (y*), the supervisor's state, the noise
    generator's state and the plant's contact-solver cache."""
    xs: np.ndarray
    ys: np.ndarray
    xo: np.ndarray
    xe: np.ndarray
    xl: np.ndarray
    yl: np.ndarray
    xq: np.ndarray
    xf: np.ndarray
    yf: np.ndarray
    sv: np.ndarray  # the supervisor's state (rt.loop.supervisor.SUPERVISOR_SLOTS)
    xa: np.ndarray
    ya: np.ndarray
    xp: np.ndarray
    yp: np.ndarray
    rng: np.ndarray
    plant_work: object  # PlantWork: its cached contact factors decide round-off, so they carry over
    xsh: np.ndarray     # the shaker's armature [x_a, x_a'] (plant.shaker), at rest 0
    k: int = 0  # the next tick to run

    def copy(self) -> LoopState:
        new = {n: (v.copy() if isinstance(v, np.ndarray) else v) for n, v in vars(self).items()}
        new["plant_work"] = type(self.plant_work)(*(a.copy() for a in self.plant_work))
        return LoopState(**new)


def initial_loop_state(loop: Loop, seed: int) -> LoopState:
    """At rest at F_N1 = F0 (0 V), every filter at its steady state; noise seeded with seed."""
    cfg = loop.cfg
    plant = loop.plant
    xa = actuator_initial_state(loop.actuator, V=cfg.actuator.V_min)
    ya = np.zeros(len(ACTUATOR_OUTPUTS))
    ya[0] = loop.actuator.F0 + loop.actuator.k_screw * xa[3]
    ai = actuator_output_index()
    ya[ai["F_strain_a"]] = ya[ai["F_cell_a"]] = ya[0]
    ys = np.zeros(len(SENSOR_OUTPUTS))
    si = sensor_output_index()
    ys[si["F_strain"]] = ys[si["F_cell"]] = ya[0]  # the readings at rest (noise-free)
    # the sensors' sampled-force filters carry dF_N1 in the loop's form: 0 at rest (g = g_ref)
    return LoopState(xs=sensors_initial_state(loop.sensors, F_N1=0.0), ys=ys,
                     xo=rest_state(loop.oracle, (0.0, 0.0)), xe=np.zeros(loop.observer.M.shape[0]), xl=np.zeros(len(LAWS_SLOTS)),
                     yl=np.zeros(len(LAWS_OUTPUTS)), xq=rest_state(loop.prefilter, (cfg.tracking.F_min_N,)),
                     xf=tracking_initial_state(ya[0]), yf=np.zeros(len(FORCE_TRACKING_OUTPUTS)),
                     sv=supervisor_initial_state(ys), xa=xa, ya=ya,
                     xp=plant.initial_state(cfg.actuator.F0_N), yp=np.zeros(len(plant.output_labels())),
                     rng=new_rng(seed), plant_work=plant.new_work(), xsh=np.zeros(2))


@dataclass
class Run:
    """A finished (or interrupted) run: the log and its figures."""
    loop: Loop
    freq_hz: float
    amp_n: float
    log: np.ndarray            # (rows, len(loop.signals)): every tick, or a ring run's last rows (``run``)
    comp_ns: np.ndarray | None  # (rows, len(COMPONENTS)) if timed, the same ticks
    overruns: int
    paced: bool
    wall_ns: int
    interrupted: bool = False  # stopped by Ctrl-C: the log holds the ticks run until then
    final: LoopState | None = None  # every state after the last tick run (a next run's start)
    faults: np.ndarray | None = None  # the injected fault schedule (rt.loop.faults)
    ticks: int | None = None  # ticks run (None: len(log), every tick held)
    digest: object = None  # a ring run's whole-run figures (rt.loop.digest.RunDigest), if its writer kept them

    def __post_init__(self):
        if self.ticks is None:
            self.ticks = len(self.log)

    def signal(self, name: str) -> np.ndarray:
        return self.log[:, self.loop.column(name)]


MAX_LOG_BYTES = 4 * 2**30  # a run's log must fit in memory with room to spare


def check_run_input(loop: Loop, freq_hz: float, amp_n: float, duration_s: float, ring: bool = False) -> int:
    """Number of ticks of a run; ValueError (naming the option and the limit) for an excitation
    at or above Nyquist, a negative amplitude or duration, or (without a ring: ``run``) a log
    that would not fit in memory."""
    dt = loop.cfg.dt_s
    nyq = 0.5 / dt
    if not (math.isfinite(freq_hz) and 0.0 <= freq_hz < nyq):
        raise ValueError(f"--freq {freq_hz:g} Hz: must lie in [0, {nyq:g}) Hz (below the Nyquist frequency)")
    if not (math.isfinite(amp_n) and amp_n >= 0.0):
        raise ValueError(f"--amp {amp_n:g} N: must be a finite force >= 0 N")
    if not (math.isfinite(duration_s) and duration_s > 0.0):
        raise ValueError(f"--duration {duration_s:g} s: must be > 0 s")
    n_ticks = int(round(duration_s / dt))
    n_sig = len(loop.signals)
    if not ring and n_ticks * n_sig * 8 > MAX_LOG_BYTES:
        raise ValueError(f"--duration {duration_s:g} s: the log would need "
                         f"{n_ticks * n_sig * 8 / 2**30:.1f} GiB (> {MAX_LOG_BYTES / 2**30:.0f} GiB); "
                         f"run at most {MAX_LOG_BYTES / (n_sig * 8) * dt:.0f} s")
    return n_ticks


def run(loop: Loop, freq_hz: float, amp_n: float, duration_s: float, *, paced: bool = False,
        timing: bool = False, seed: int | None = None, chunk: int = 21000, progress=None,
        start: LoopState | None = None, writer=None, faults: np.ndarray | None = None,
        ring_ticks: int | None = None) -> Run:
    """Run the closed loop for duration_s [s] with a sine excitation amp_n sin(2 pi freq_hz t).

    The run starts at rest (``initial_loop_state``) or from ``start`` (e.g. the ``final`` state
    of a previous run: a step-sine continues from the previous frequency's state; that start
    is not modified). Ticks continue from the start's tick k (t = k dt), so a run split in two
    at the same frequency equals one run, bit for bit.

    ``faults``: a fault schedule (``rt.loop.faults.schedule``; ticks absolute, so a split run takes
    the same schedule), none by default.

    ``writer`` (an ``rt.log.writer.LogWriter``) drains the log to files while the loop runs: its
    ``start(log, clk, k0, paced)`` is called before the first tick, its ``finish()`` (write the
    rest, close the files) after the last one, also on an error or Ctrl-C.

    The log: without a writer and ``ring_ticks``, one row per tick of the run. With a writer
    (its ``ring_ticks`` rows) or ``ring_ticks``, a ring of R rows: tick k goes to row
    (k - k_start) mod R, offline the loop waits for the writer rather than overwrite a row it
    has not taken (none: nobody drains, the loop overwrites), paced it never waits (the writer
    drops what was overwritten). ``Run.log`` then holds the last min(ticks, R) ticks in tick
    order, ``Run.ticks`` the count, ``Run.digest`` the writer's whole-run figures (``summary``).

    Raises ValueError for an excitation above Nyquist, a negative amplitude or duration, or a
    log without a ring that would not fit in memory; RuntimeError if a plant step failed.
    """
    cfg = loop.cfg
    dt = cfg.dt_s
    if writer is not None:
        ring_ticks = writer.ring_ticks
    if ring_ticks is not None and ring_ticks < 1:
        raise ValueError(f"ring_ticks {ring_ticks}: must be >= 1")
    n_ticks = check_run_input(loop, freq_hz, amp_n, duration_s, ring=ring_ticks is not None)
    n_rows = n_ticks if ring_ticks is None else min(n_ticks, int(ring_ticks))
    n_sig = len(loop.signals)
    seed = cfg.rt.seed if seed is None else seed
    plant = loop.plant
    oi = plant.output_index()
    ai = actuator_output_index()
    st = initial_loop_state(loop, seed) if start is None else start.copy()
    log = np.empty((n_rows, n_sig))
    comp_ns = np.zeros((n_rows, len(COMPONENTS)), dtype=np.int64) if timing else np.zeros((1, 1), np.int64)
    period_ns = int(round(dt * 1e9))
    clk = np.zeros(CLK_SIZE, dtype=np.int64)
    clk[CLK_WRITTEN] = st.k if writer is not None and not paced else NO_WAIT
    si = sensor_output_index()
    exc = cfg.plant.excitation_point
    force_col = si["F_strain" if loop.force_sensor == "strain" else "F_cell"]
    faults = no_faults() if faults is None else np.ascontiguousarray(faults, dtype=np.float64)
    args_fixed = (dt, amp_n, 2 * math.pi * freq_hz, force_col, timing, paced, period_ns, clk,
                  np.zeros(2, dtype=np.int64))
    failed = [0]
    errors: list[BaseException] = []

    def worker():
        try:
            _chunks()
        except BaseException as exc:  # re-raised in the calling thread
            errors.append(exc)

    def _chunks():
        # paced: one compiled call for the whole run (Python between chunks would overrun);
        # a ring: chunks of whole rings, so that tick k lands in row (k - st.k) mod n_rows
        step = n_ticks if paced else (chunk if n_rows == n_ticks else max(1, chunk // n_rows) * n_rows)
        k = 0  # ticks run; tick st.k + k
        while k < n_ticks and not clk[CLK_STOP]:
            k1 = min(n_ticks, k + step)
            rows = slice(k, k1) if n_rows == n_ticks else slice(None)
            failed[0] += _run_ticks(st.k + k, st.k + k1, *args_fixed,
                                    st.xs, np.empty_like(st.xs), st.ys, np.empty_like(st.ys), np.empty_like(st.ys),
                                    np.zeros(5), loop.sensors, st.rng,
                                    loop.estimator == "observer", st.xo, np.empty_like(st.xo),
                                    np.zeros(len(ORACLE_OUTPUTS)), np.zeros(2), loop.oracle, st.xe,
                                    np.empty_like(st.xe), np.zeros(len(OBSERVER_OUTPUTS)), np.zeros(2),
                                    loop.observer,
                                    st.xl, np.empty_like(st.xl), st.yl, np.zeros(2), loop.law_params,
                                    st.sv, np.zeros(len(SUPERVISOR_OUTPUTS)), loop.supervisor, faults,
                                    st.xq, np.empty_like(st.xq), np.zeros(1), np.zeros(1), loop.prefilter,
                                    st.xf, np.empty_like(st.xf), st.yf, np.zeros(2), loop.design.params,
                                    st.xa, np.empty_like(st.xa), st.ya, np.zeros(1), loop.actuator,
                                    st.xp, np.empty_like(st.xp), st.yp, np.zeros(2), plant.params, st.plant_work,
                                    cfg.shaker.on, st.xsh, np.empty_like(st.xsh), np.zeros(3), np.zeros(1),
                                    loop.shaker,
                                    oi["u_rel"], oi["v_rel"], oi["abar_tip"], oi["abar_frf"],
                                    ai["F_strain_a"], ai["F_cell_a"], oi["dF_N1"], oi[f"w_{exc}"], oi[f"v_{exc}"],
                                    log[rows], comp_ns[rows] if timing else comp_ns)
            k = k1

    # the compiled loop holds no GIL (nogil): it runs in its own thread while this one shows
    # progress and turns Ctrl-C into a stop request; the ticks run so far are kept
    t_wall = _now_ns(np.zeros(2, dtype=np.int64))
    clk[CLK_DEADLINE] = t_wall + period_ns
    thread = threading.Thread(target=worker, name="frictionrt-loop", daemon=True)
    digest = None
    if writer is not None:
        from rt.loop.digest import RunDigest
        digest = RunDigest(loop.signals)
        writer.start(log, clk, st.k, paced, digest)
    thread.start()
    shown = 0
    interrupted = False
    try:
        while thread.is_alive():
            try:
                thread.join(0.1)
            except KeyboardInterrupt:
                clk[CLK_STOP] = 1
                interrupted = True
            if progress is not None:
                ticks = int(clk[CLK_TICKS])
                progress(ticks - shown)
                shown = ticks
    finally:
        if writer is not None:  # the log's rows are final once the loop's thread has ended
            if thread.is_alive():  # an exception here: stop the loop first
                clk[CLK_STOP] = 1
                thread.join()
            writer.finish()
    if errors:
        raise errors[0]
    n_run = int(clk[CLK_TICKS])
    st.k += n_run
    log = _in_tick_order(log, n_run)
    comp_ns = _in_tick_order(comp_ns, n_run) if timing else comp_ns
    wall = _now_ns(np.zeros(2, dtype=np.int64)) - t_wall
    if writer is not None and writer.error is not None:
        raise RuntimeError(f"the log writer failed: {writer.error!r}") from writer.error
    if failed[0]:
        raise RuntimeError(f"the plant's contact solve failed in {failed[0]} of {n_run} ticks; "
                           "raise plant.substeps (e.g. --set plant.substeps=2) or plant.fallback_split")
    if not np.all(np.isfinite(log) | _dropout_mask(loop, faults, st.k - len(log), len(log))):
        raise RuntimeError("the loop produced NaN/Inf: check the configuration and the excitation")
    return Run(loop, freq_hz, amp_n, log, comp_ns if timing else None, int(clk[CLK_OVERRUNS]), paced, int(wall),
               interrupted, st, faults, n_run, digest if len(log) < n_run else None)


def _in_tick_order(ring: np.ndarray, n_run: int) -> np.ndarray:
    """The last min(n_run, len(ring)) ticks of a log whose tick i (from the run's start) is in
    row i mod len(ring), oldest first (a view when they are in order already)."""
    if n_run <= len(ring):
        return ring[:n_run]
    i0 = n_run % len(ring)
    return ring if i0 == 0 else np.concatenate((ring[i0:], ring[:i0]))


def _dropout_mask(loop: Loop, faults: np.ndarray, k0: int, n: int) -> np.ndarray:
    """True where an injected sensor_dropout makes a logged reading NaN (rows k0 .. k0 + n - 1)."""
    mask = np.zeros((n, len(loop.signals)), dtype=bool)
    for f in faults:
        if int(f[F_KIND]) == K_DROPOUT:
            lo, hi = max(int(f[F_START]) - k0, 0), min(int(min(f[F_END], 2**62)) - k0, n)
            if lo < hi:
                mask[lo:hi, 1 + int(f[F_TARGET])] = True  # column 0 is F_exc, then SENSOR_OUTPUTS
    return mask


def first_harmonic_amplitude(x: np.ndarray, freq_hz: float, dt: float) -> float:
    """Amplitude of the component at freq_hz of x (least squares on sin, cos, offset) over the
    whole periods at the end of x."""
    n_per = 1.0 / (freq_hz * dt)
    n = int(np.floor(len(x) / n_per) * n_per) if freq_hz > 0 else len(x)
    n = max(n, 2)
    t = (np.arange(len(x) - n, len(x))) * dt
    A = np.column_stack([np.sin(2 * np.pi * freq_hz * t), np.cos(2 * np.pi * freq_hz * t), np.ones(n)])
    c, *_ = np.linalg.lstsq(A, x[-n:], rcond=None)
    return float(np.hypot(c[0], c[1]))


def _tail(r: Run) -> slice:
    """The log's rows of the last 20 % of the run's ticks (at least 2), at most the rows held."""
    n = len(r.log)
    return slice(max(n - max(int(0.2 * r.ticks), 2), 0), n)


def summary(r: Run) -> dict:
    """The figures `frictionrt simulate` prints (SI units). A ring run whose log holds only its
    last ticks takes the whole-run figures (mean F_N1, tick median and maximum, trips, faults)
    from its digest (``rt.loop.digest``), the last-20 % figures from the rows held (docs/loop.md)."""
    dt = r.loop.cfg.dt_s
    tail = _tail(r)
    a = r.signal("a_frf")
    d = r.digest
    return {
        "law": r.loop.law, "estimator": r.loop.estimator, "freq_hz": r.freq_hz, "amp_n": r.amp_n, "ticks": r.ticks,
        "acc045_amplitude": first_harmonic_amplitude(a[tail], r.freq_hz, dt),
        "acc045_rms": float(np.sqrt(np.mean(a[tail] ** 2))),
        "acc045_peak": float(np.max(np.abs(a[tail]))),
        "fn1_mean_n": float(np.mean(r.signal("F_N1"))) if d is None else d.fn1_mean(),
        "actuator_energy_j": float(r.signal("E")[-1]),
        "overruns": r.overruns, "paced": r.paced,
        "tick_median_us": float(np.median(r.signal("tick_ns")) if d is None else d.tick_median()) / 1e3,
        "tick_max_us": float(np.max(r.signal("tick_ns")) if d is None else d.tick_max()) / 1e3,
        "wall_s": r.wall_ns / 1e9,
    } | _supervisor_summary(r) | (_estimation_errors(r) if r.loop.estimator != "oracle" else {})


def _supervisor_summary(r: Run) -> dict:
    """``trips``: every latched fault (code, name, tick, recovered_tick); ``faults``: per injected
    fault its kind, sensor, tick, and the code, detected_tick, passive_tick the supervisor logged
    (``rt.loop.faults.outcome``). Ticks are absolute."""
    from rt.loop.faults import outcome, trips
    p = r.loop.supervisor
    grace = 2 * max(p.stuck_ticks, p.err_ticks, p.sat_ticks, p.ovr_ticks) + 100
    faults = r.faults if r.faults is not None else np.zeros((0, 5))
    if r.digest is None:
        k = r.final.k - len(r.log) + np.arange(len(r.log))
        latched, code, passive = r.signal("fault_latched"), r.signal("fault_code"), r.signal("passive")
    else:  # the step signals at their changes (and the faults' starts): the same trips and outcome
        k = r.digest.change_ticks(faults[:, F_START])
        latched, code, passive = (r.digest.values_at(n, k) for n in ("fault_latched", "fault_code", "passive"))
    return {"trips": trips(k, latched), "faults": outcome(k, code, passive, faults, grace)}


def _estimation_errors(r: Run) -> dict:
    """NRMSE of the estimates against the band-limited plant truth (observer.accuracy), and
    the relative error of the law's RT1 amplitude u0 against the RT1 filter's steady state on
    the truth, the mean of (pi/2)|u_rel| (tracking.rt1), both over the last 20 % (over the
    rows held: a ring run's last ticks)."""
    cfg = r.loop.cfg
    dt, f_c = cfg.dt_s, cfg.observer.oracle_bandwidth_hz
    v_true = band_limited_truth(r.signal("v_rel"), dt, f_c)
    u_true = band_limited_truth(r.signal("u_rel"), dt, f_c)
    tail = _tail(r)
    u0_true = float(np.mean(0.5 * np.pi * np.abs(u_true[tail])))
    u0_hat = float(np.mean(r.signal("u0")[tail]))
    return {"v_rel_nrmse": nrmse(r.signal("v_rel_hat"), v_true), "u_rel_nrmse": nrmse(r.signal("u_rel_hat"), u_true),
            "u0_rel_error": (u0_hat - u0_true) / u0_true if u0_true > 0 else float("nan")}
