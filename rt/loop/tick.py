"""The hard fixed-step loop (SPEC section 7): every tick of a run inside one compiled function.

One tick k, t_k = k dt (int64 tick, never accumulated time), in this fixed order:

    1 sensors    mean accelerations of the plant over the last tick (plant outputs abar_*) and the
                 bolt-force sensors' analog outputs of the stack force
                 (integrated inside the actuator, exact between samples) plus the bolt's response
                 to the beams' separation (plant output dF_N1) -> ADC readings of the bolt force
    2 estimator  oracle: the plant's true u_rel, v_rel at t_k, band-limited (observer.oracle),
                 or observer: the Kalman-designed nonlinear observer on the measured tip
                 velocity and the force cell's F_N (observer.step), or its amplitude-following
                 kind (observer.amplitude_step; est's amplitude grid not empty)
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
wall clock (rt/loop/pacing.py, shared with the replay): absolute deadlines next += period,
overruns counted and skipped by whole periods, each tick's execution time and lateness logged.
Ticks run in chunks so that Python can show progress between them (rt/loop/driver.py); the
deadline carries over.

Stages 2-4 with the supervisor are one function, ``_controller_tick``, which the replay
(``frictionrt.rt.loop.replay``) runs on logged readings. Injected faults (``frictionrt.rt.loop.faults``) act on the readings
after the ADC (stage 1), the observer's input, the amplifier's input (stage 5) and as a busy
delay (cpu_stall).
"""
from __future__ import annotations

import math

import numba

from frictionrt.observer.amplitude_step import _amplitude_step
from frictionrt.observer.step import _observer_step
from frictionrt.plant.actuator import _actuator_step
from frictionrt.plant.plant_step import plant_step
from frictionrt.plant.sensors import _sensors_read, _tip_velocity
from frictionrt.plant.sensors import output_index as sensor_output_index
from frictionrt.plant.shaker import _shaker_step
from frictionrt.rt.common.clock import CLK_DEADLINE, CLK_STOP, CLK_TICKS, CLK_WRITTEN, _now_ns
from frictionrt.rt.loop.keyframe import _keyframe_put
from frictionrt.rt.loop.pacing import _next_deadline, _wait_for_deadline
from frictionrt.rt.loop.supervisor import (S_OVERRAN, S_PASSIVE, _inject_actuator, _inject_observer, _inject_sensors, _sanitise,
                                _stall_ns, _supervise, _supervise_after)
from frictionrt.tracking.force_tracking import _force_tracking_step
from frictionrt.tracking.laws import _laws_step
from frictionrt.tracking.lowpass import _biquad_step

COL_V_TIP, COL_F_CELL = sensor_output_index()["v_tip_meas"], sensor_output_index()["F_cell"]  # the observer's inputs


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
    xa_n, xp_n. The loop and the plant replay (``frictionrt.rt.loop.replay_plant``) both call this. Returns
    (the plant's Newton iterations, -1 on a failed solve; the clock [ns] after the actuator
    if timing, else 0). RT-safe."""
    F_start = ya[0]
    ua[0] = V_cmd
    _actuator_step(k, xa, ua, act_p, xa_n, ya)
    t5 = _now_ns(ts) if timing else 0
    up[0] = F_exc
    up[1] = 0.5 * (F_start + ya[0])
    return plant_step(k, xp, up, plant_p, xp_n, yp, plant_wk), t5


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _controller_tick(k, ys, yc, u_rel, v_rel, force_col, observe, faults, timing, ts, est, law, sup, trk):
    """Stages 2-4 of tick k with the supervisor, on the readings ys (``SENSOR_OUTPUTS``) and the
    plant's u_rel [m], v_rel [m/s] (read by the oracle only): the loop and the replay both run
    this. The stages' arrays come in four tuples (a call of more than ~30 arguments cannot be
    inlined): est = (xo, xo_n, yo, uo, oracle_p, xe, xe_n, ye, ue, obs_p, amp_p, we), law = (xl, xl_n, yl,
    ul, law_p), sup = (sv, ysv, sv_p), trk = (xq, xq_n, yq, uq, pre_p, xf, xf_n, yf, uf, ft_p). yc receives the readings the controller uses (non-finite ones replaced by the last
    finite, ``frictionrt.rt.loop.supervisor._sanitise``); ye, yl, yq, yf, ysv the stages' outputs; next states
    into x*_n; the supervisor state sv is advanced in place. Returns the clock [ns] after the
    estimator, the law, the supervisor and the tracking if timing, else zeros. RT-safe."""
    xo, xo_n, yo, uo, oracle_p, xe, xe_n, ye, ue, obs_p, amp_p, we = est
    xl, xl_n, yl, ul, law_p = law
    sv, ysv, sv_p = sup
    xq, xq_n, yq, uq, pre_p, xf, xf_n, yf, uf, ft_p = trk
    # 2 estimator (oracle: the plant's u_rel, v_rel band-limited)
    _sanitise(sv, ys, yc)
    if observe:
        ue[0] = yc[COL_V_TIP]
        ue[1] = yc[COL_F_CELL]
        _inject_observer(k, faults, ue)
        if amp_p.grid.shape[0] > 0:  # the amplitude-following kind
            _amplitude_step(k, xe, ue, obs_p, amp_p, we, xe_n, ye)
        else:
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


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _controller_done(out, row, c, observe, est, law, sup, trk):
    """After ``_controller_tick``: its outputs (estimator, law, prefilter, force tracking,
    supervisor: ``COMMANDED`` order) into out[row, c:], and its next states become its states.
    The loop and the replay both call it. Returns the next column. RT-safe."""
    xo, xo_n, yo, uo, oracle_p, xe, xe_n, ye, ue, obs_p, amp_p, we = est
    xl, xl_n, yl, ul, law_p = law
    sv, ysv, sv_p = sup
    xq, xq_n, yq, uq, pre_p, xf, xf_n, yf, uf, ft_p = trk
    c = _put(out, row, c, ye)
    c = _put(out, row, c, yl)
    c = _put(out, row, c, yq)
    c = _put(out, row, c, yf)
    c = _put(out, row, c, ysv)
    if observe:
        _copy(xe_n, xe)
    else:
        _copy(xo_n, xo)
    _copy(xl_n, xl)
    _copy(xq_n, xq)
    _copy(xf_n, xf)
    return c


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _tick_begin(k, k0, pace, faults, sens, act, plnt, cols, log, kf):
    """The start of tick k of ticks run from k0 into ``log`` and its stage 1. Returns (its row
    (k - k0) mod len(log), the clock [ns] at its start, its lateness [ns] (paced, else 0)), or
    row -1 on a stop request (nothing done).

    Offline (not paced) a ring row is never overwritten before the writer has taken it: the tick
    first spins (nogil) while k - clk[CLK_WRITTEN] >= len(log); paced, it waits for its deadline
    (rt/loop/pacing.py). Stage 1: the plant accelerations and the force sensors' analog outputs
    at t_k through the sensors (ADC readings into ys); injected faults act on the readings, before
    the controller's tip integrator (ys[2] = v_tip_meas); then an injected CPU stall. Arguments
    as ``_run_ticks`` takes them. The loop and the C controller's loop (rt/export/sil.py) both
    call this. With kf (``_run_ticks``) a key frame of tick k is copied before stage 1. RT-safe."""
    timing, paced, period_ns, margin_ns, clk, ts = pace
    xs, xs_n, ys, ys_prev, yc, us, sens_p, rng = sens
    ya, yp = act[2], plnt[2]
    col_urel, col_vrel, col_a_tip, col_a_frf, col_strain, col_cell, col_dF, col_w_exc, col_v_exc = cols
    if clk[CLK_STOP]:
        return -1, 0, 0
    row = (k - k0) % log.shape[0]
    if not paced:  # the ring's row of tick k - len(log) must be out (the clock call re-reads clk)
        while k - clk[CLK_WRITTEN] >= log.shape[0] and not clk[CLK_STOP] and _now_ns(ts) > 0:
            pass
        if clk[CLK_STOP]:
            return -1, 0, 0
    if paced:
        _wait_for_deadline(clk, ts, margin_ns)
    t_start = _now_ns(ts)
    late = t_start - clk[CLK_DEADLINE] if paced else 0
    _keyframe_put(k, kf)   # the state between ticks k - 1 and k (its ring row is free: the wait above)
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
    return row, t_start, late


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _tick_plant(k, V_cmd, exc, faults, act, plnt, shk, cols, timing, ts):
    """Stages 5s, 5 and 6 of tick k: the drive (through the shaker if it runs), the actuator on
    the command V_cmd [V] (injected faults act on it) and the plant over the tick. exc, act, plnt,
    shk, cols as ``_run_ticks`` takes them. Returns (F_exc [N], the plant's Newton iterations or
    -1 on a failed solve, the clock [ns] after the actuator if timing). RT-safe."""
    dt, exc_amp, exc_omega = exc
    xa, xa_n, ya, ua, act_p = act
    xp, xp_n, yp, up, plant_p, plant_wk = plnt
    shake, xsh, xsh_n, ush, ysh, sh_p = shk
    col_urel, col_vrel, col_a_tip, col_a_frf, col_strain, col_cell, col_dF, col_w_exc, col_v_exc = cols
    F_exc = exc_amp * math.sin(exc_omega * (k * dt))   # the drive (an ideal source's force)
    if shake:  # 5s: the force the structure gets through the stinger (its time counts as the actuator's)
        ush[0] = F_exc
        ush[1] = yp[col_w_exc]
        ush[2] = yp[col_v_exc]
        _shaker_step(k, xsh, ush, sh_p, xsh_n, ysh)
        F_exc = ysh[0]
    iters, t5 = _actuate(k, F_exc, _inject_actuator(k, faults, V_cmd), xa, xa_n, ya, ua, act_p,
                         xp, xp_n, yp, up, plant_p, plant_wk, timing, ts)
    return F_exc, iters, t5


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _tick_log(log, row, c, t_start, late, sens, act, plnt, shk, ts):
    """The end of stage 7 once the readings and the controller's outputs are in log[row, :c]:
    the actuator's and the plant's outputs, the states advanced, then tick_ns (from t_start
    [ns]) and late_ns. Returns the clock [ns] at the tick's end. RT-safe."""
    xs, xs_n, ys, ys_prev, yc, us, sens_p, rng = sens
    xa, xa_n, ya, ua, act_p = act
    xp, xp_n, yp, up, plant_p, plant_wk = plnt
    shake, xsh, xsh_n, ush, ysh, sh_p = shk
    c = _put(log, row, c, ya)
    c = _put(log, row, c, yp)
    _copy(xs_n, xs)
    _copy(xa_n, xa)
    _copy(xp_n, xp)
    if shake:
        _copy(xsh_n, xsh)
    t_end = _now_ns(ts)
    log[row, c] = t_end - t_start
    log[row, c + 1] = late
    return t_end


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _tick_done(clk, paced, period_ns, t_end):
    """The tick counted (the writer may take its row) and, paced, the next deadline after t_end
    [ns]. Returns True on an overrun (the controller's supervisor reads it next tick). RT-safe."""
    clk[CLK_TICKS] += 1
    return paced and _next_deadline(clk, period_ns, t_end)


@numba.njit(cache=True, nogil=True, _nrt=False)  # no allocation, no reference counting
def _run_ticks(k0, k1, exc, pace, force_col, observe, faults, sens, est, law, sup, trk, act, plnt, shk, cols,
               log, comp_ns, kf):
    """Run ticks k0 <= k < k1 (see the module docstring); states are advanced in place.

    The stages' arrays come in tuples (x: state, x_n: next state, y: outputs, u: inputs, p:
    constants): exc = (dt [s], amplitude [N], omega [rad/s]) of the drive; pace = (timing,
    paced, period_ns, margin_ns, clk, ts): the sleep margin before each deadline [ns]
    (rt/loop/pacing.py), clk the shared clock slots (rt/common/clock.py), ts the clock's (2,)
    int64 scratch; sens = (xs, xs_n, ys, ys_prev, yc, us, sens_p, rng); est, law, sup, trk
    as ``_controller_tick`` takes them; act = (xa, xa_n, ya, ua, act_p); plnt = (xp, xp_n, yp,
    up, plant_p, plant_wk); shk = (shake, xsh, xsh_n, ush, ysh, sh_p); cols = the columns of yp
    and ya the stages read (u_rel, v_rel, abar_tip, abar_frf, F_strain_a, F_cell_a, dF_N1, w and
    v at the excitation point); kf = (interval, float64 ring, int64 ring, float64 parts, int64
    parts): the key frames (``frictionrt.rt.loop.keyframe._keyframe_put``, at the start of every tick
    that is a multiple of the interval, once its ring row may be overwritten; interval 0: none).

    observe selects the estimator: False the oracle (states xo), True the observer (states xe;
    inputs: the measured tip velocity and force-cell reading). faults: the fault schedule
    (``frictionrt.rt.loop.supervisor``, (0, 5) for none). shake: the shaker stage runs (states xsh; inputs
    the drive and the plant's w, w' at the excitation point); False: F_exc = drive (ideal source).
    log[(k - k0) mod len(log)] receives the tick's signals (``loop_signals`` order): a log of
    k1 - k0 rows is filled in order, a shorter one is a ring (``run``); comp_ns the same row's
    per-component times [ns] if timing. Offline (not paced) a ring row is never overwritten
    before the writer has taken it: before tick k the loop spins (nogil) while k -
    clk[CLK_WRITTEN] >= len(log) (``NO_WAIT`` without a writer), and ends early on a stop
    request. Returns the number of failed plant solves.

    Each tick is ``_tick_begin`` (with stage 1), the controller (``_controller_tick``),
    ``_tick_plant``, the log (``_controller_done``, ``_tick_log``) and ``_tick_done``: the C
    controller's loop (rt/export/sil.py) is the same but for the controller.
    """
    timing, paced, period_ns, margin_ns, clk, ts = pace
    ys, yc = sens[2], sens[4]   # the readings, and those the controller uses
    sv = sup[0]
    yf = trk[7]   # the force tracking's outputs: V_cmd, saturated
    yp = plnt[2]
    failed = 0
    for k in range(k0, k1):
        # the ring's row, the deadline; 1 sensors (injected faults on the readings, before the tip integrator)
        row, t_start, late = _tick_begin(k, k0, pace, faults, sens, act, plnt, cols, log, kf)
        if row < 0:
            break
        t1 = _now_ns(ts) if timing else 0
        # 2 estimator, 3 law, 3s supervisor, 4 force tracking
        t2, t3, t3s, t4 = _controller_tick(k, ys, yc, yp[cols[0]], yp[cols[1]], force_col, observe, faults,
                                           timing, ts, est, law, sup, trk)
        # 5 actuator (faults act on its input), 5s shaker and 6 plant over the tick
        F_exc, iters, t5 = _tick_plant(k, yf[0], exc, faults, act, plnt, shk, cols, timing, ts)
        if iters < 0:
            failed += 1
        t6 = _now_ns(ts) if timing else 0
        # 7 log and advance the states
        log[row, 0] = F_exc
        c = _put(log, row, 1, ys)
        c = _controller_done(log, row, c, observe, est, law, sup, trk)
        t_end = _tick_log(log, row, c, t_start, late, sens, act, plnt, shk, ts)
        if timing:
            comp_ns[row, 0] = t1 - t_start
            comp_ns[row, 1] = t2 - t1
            comp_ns[row, 2] = t3 - t2
            comp_ns[row, 3] = t3s - t3
            comp_ns[row, 4] = t4 - t3s
            comp_ns[row, 5] = t5 - t4
            comp_ns[row, 6] = t6 - t5
            comp_ns[row, 7] = t_end - t6
        # the supervisor's overrun check reads the flag next tick
        sv[S_OVERRAN] = 1.0 if _tick_done(clk, paced, period_ns, t_end) else 0.0
    return failed
