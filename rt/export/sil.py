"""Software in the loop: the compiled C export as the controller of the numba loop
(``frictionrt simulate --controller c:DIR``).

``CController(loop, folder, seed)`` is a controller for ``rt.loop.driver.run(..., controller=)``:
the loop's ticks as rt/loop/tick.py ``_run_ticks`` runs them offline (sensors, actuator, shaker,
plant in numba; ring rows, the writer's pace, stop requests, the deadlines of a paced run and its
overruns, which the C's supervisor reads as the numba one does), with stages 2-4 (estimator, law,
supervisor, prefilter, force tracking) and the tip integrator's output taken from the C export's
``ctrl_step_flat`` (ctrl_batch.c) instead of ``_controller_tick``. The C function reaches the
cached kernel as a ctypes function argument (numba calls it from nopython code through the
address it gets at run time). The log has the loop's columns; tick_ns is the tick's time with the
C, late_ns its lateness (paced). ``run_sil`` runs a whole offline log.
"""
from __future__ import annotations

import ctypes
import math

import numba
import numpy as np

from plant.sensors import _sensors_read, _tip_velocity
from plant.shaker import _shaker_step
from rt.common.clock import CLK_DEADLINE, CLK_STOP, CLK_TICKS, CLK_WRITTEN, _now_ns
from rt.export.cbuild import N_OUTPUTS, build
from rt.export.generate import read_manifest
from rt.export.record import controller_record, design_hash
from rt.loop.build import initial_loop_state
from rt.loop.pacing import _next_deadline, _wait_for_deadline
from rt.loop.supervisor import _inject_actuator, _inject_sensors, _stall_ns
from rt.loop.driver import run
from rt.loop.tick import _actuate, _copy, _put


@numba.njit(cache=True, nogil=True, _nrt=False)
def _sil_ticks(k0, k1, exc, pace, faults, sens, cstep, ctl, act, plnt, shk, cols, log):
    """Ticks k0 <= k < k1 of the loop (``rt.loop.tick._run_ticks``, untimed) with the C
    controller cstep (``ctrl_step_flat``); ctl = (its state buffer, input (8,), output (13,)).
    Log row (k - k0) mod len(log) receives the tick's signals. Returns failed plant solves.
    RT-safe."""
    dt, exc_amp, exc_omega = exc
    timing, paced, period_ns, margin_ns, clk, ts = pace
    cstate, cin, cout = ctl
    xs, xs_n, ys, ys_prev, yc, us, sens_p, rng = sens
    xa, xa_n, ya, ua, act_p = act
    xp, xp_n, yp, up, plant_p, plant_wk = plnt
    shake, xsh, xsh_n, ush, ysh, sh_p = shk
    col_urel, col_vrel, col_a_tip, col_a_frf, col_strain, col_cell, col_dF, col_w_exc, col_v_exc = cols
    failed = 0
    for k in range(k0, k1):
        if clk[CLK_STOP]:
            break
        row = (k - k0) % log.shape[0]
        if not paced:
            while k - clk[CLK_WRITTEN] >= log.shape[0] and not clk[CLK_STOP] and _now_ns(ts) > 0:
                pass   # the ring's row of tick k - len(log) must be out (the clock call re-reads clk)
            if clk[CLK_STOP]:
                break
        if paced:
            _wait_for_deadline(clk, ts, margin_ns)
        t_start = _now_ns(ts)
        late = t_start - clk[CLK_DEADLINE] if paced else 0
        # 1 sensors, injected sensor faults, the numba integrator (its state advances as the loop's)
        us[0] = yp[col_a_tip]
        us[1] = yp[col_a_frf]
        us[2] = ya[col_strain]
        us[3] = ya[col_cell]
        us[4] = yp[col_dF]
        _copy(ys, ys_prev)
        _sensors_read(k, xs, us, sens_p, xs_n, ys, rng)
        _inject_sensors(k, faults, ys, ys_prev, sens_p)
        _tip_velocity(xs, sens_p, xs_n, ys)
        stall = _stall_ns(k, faults)
        if stall > 0:
            t_stall = _now_ns(ts) + stall
            while _now_ns(ts) < t_stall:
                pass
        # 2-4 the C controller on the ADC readings (it integrates a_tip_meas itself)
        cin[0] = k
        cin[1] = ys[0]
        cin[2] = ys[1]
        cin[3] = ys[3]
        cin[4] = ys[4]
        cin[6] = yp[col_urel]
        cin[7] = yp[col_vrel]
        cstep(cstate.ctypes.data, cin.ctypes.data, faults.ctypes.data, faults.shape[0], cout.ctypes.data)
        # 5 actuator on the C's V_cmd, 5s shaker, 6 plant
        F_exc = exc_amp * math.sin(exc_omega * (k * dt))
        if shake:
            ush[0] = F_exc
            ush[1] = yp[col_w_exc]
            ush[2] = yp[col_v_exc]
            _shaker_step(k, xsh, ush, sh_p, xsh_n, ysh)
            F_exc = ysh[0]
        iters, t5 = _actuate(k, F_exc, _inject_actuator(k, faults, cout[8]), xa, xa_n, ya, ua, act_p,
                             xp, xp_n, yp, up, plant_p, plant_wk, False, ts)
        if iters < 0:
            failed += 1
        # 7 log: the readings with the C's v_tip_meas, the C's outputs, actuator, plant
        log[row, 0] = F_exc
        ys[2] = cout[0]
        c = _put(log, row, 1, ys)
        for j in range(1, cout.shape[0]):
            log[row, c + j - 1] = cout[j]
        c += cout.shape[0] - 1
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
        clk[CLK_TICKS] += 1
        cin[5] = 0.0   # the overrun flag the C's supervisor reads next tick
        if paced and _next_deadline(clk, period_ns, t_end):
            cin[5] = 1.0
    return failed


class CController:
    """The C export in ``folder`` as the controller of runs of ``loop`` started at rest with
    ``seed`` (``rt.loop.driver.run(..., controller=)``). ValueError for a folder that is no
    export, an export of another design (both hashes named), a missing compiler."""

    def __init__(self, loop, folder, seed: int, cc=None):
        m = read_manifest(folder)
        digest = design_hash(controller_record(loop, initial_loop_state(loop, seed)))
        if m["design_hash"] != digest:
            raise ValueError(f"--controller c:{folder}: an export of another design ({m['design_hash'][:19]}..., "
                             f"{m['law']}/{m['estimator']}) than this run's ({digest[:19]}..., "
                             f"{loop.law}/{loop.estimator})")
        self.build = build(folder, cc)
        lib = self.build.lib
        self.cstep = lib.ctrl_step_flat
        self.cstep.restype = None
        self.cstep.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p]
        lib.ctrl_init_flat.restype = None
        lib.ctrl_init_flat.argtypes = [ctypes.c_void_p]
        self.state = np.zeros(-(-self.build.state_bytes() // 8))   # ctrl_state, 8-byte aligned
        lib.ctrl_init_flat(self.state.ctypes.data)
        self.ctl = (self.state, np.zeros(8), np.zeros(N_OUTPUTS))
        self.design_hash = digest

    def __call__(self, k0, k1, exc, pace, faults, sens, act, plnt, shk, cols, log) -> int:
        return _sil_ticks(k0, k1, exc, pace, faults, sens, self.cstep, self.ctl, act, plnt, shk, cols, log)


def run_sil(loop, folder, freq_hz: float, amp_n: float, duration_s: float, *, seed=None, faults=None,
            cc=None) -> np.ndarray:
    """The log (ticks, len(loop.signals)) of an offline run of ``loop`` with the C export in
    ``folder`` as its controller (``CController``)."""
    seed = loop.cfg.rt.seed if seed is None else seed
    return run(loop, freq_hz, amp_n, duration_s, seed=seed, faults=faults,
               controller=CController(loop, folder, seed, cc)).log
