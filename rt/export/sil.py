"""Software in the loop: the compiled C export as the controller of the numba loop.

``run_sil(loop, folder, freq_hz, amp_n, duration_s)`` runs the closed loop as ``rt.loop.driver.run``
does offline (rt/loop/tick.py ``_run_ticks``: sensors, actuator, shaker, plant in numba), with
stages 2-4 (estimator, law, supervisor, prefilter, force tracking) and the tip integrator's
output taken from the C export's ``ctrl_step_flat`` (ctrl_batch.c) instead of
``_controller_tick``. The C function reaches the cached kernel as a ctypes function argument
(numba calls it from nopython code through the address it gets at run time). The log's columns
are the loop's (``loop.signals``); tick_ns and late_ns are 0 (not timed). A first step towards
``simulate --controller c:DIR`` (issue 33): offline, whole-run logs, no writer, no pacing.
"""
from __future__ import annotations

import ctypes
import math

import numba
import numpy as np

from plant.actuator import output_index as actuator_output_index
from plant.sensors import _sensors_read, _tip_velocity
from plant.sensors import output_index as sensor_output_index
from plant.shaker import _shaker_step
from rt.export.cbuild import N_OUTPUTS, build
from rt.export.generate import read_manifest
from rt.export.record import controller_record, design_hash
from rt.loop.build import initial_loop_state
from rt.loop.supervisor import _inject_actuator, _inject_sensors, no_faults
from rt.loop.tick import _actuate, _copy, _put


@numba.njit(cache=True, nogil=True, _nrt=False)
def _sil_ticks(k0, k1, exc, faults, sens, cstep, cstate, cin, cout, act, plnt, shk, cols, log, ts):
    """Ticks k0 <= k < k1 of the loop with the C controller cstep (``ctrl_step_flat``) on the
    state buffer cstate; log row k - k0 receives the tick's signals. Returns failed plant solves.
    RT-safe."""
    dt, exc_amp, exc_omega = exc
    xs, xs_n, ys, ys_prev, yc, us, sens_p, rng = sens
    xa, xa_n, ya, ua, act_p = act
    xp, xp_n, yp, up, plant_p, plant_wk = plnt
    shake, xsh, xsh_n, ush, ysh, sh_p = shk
    col_urel, col_vrel, col_a_tip, col_a_frf, col_strain, col_cell, col_dF, col_w_exc, col_v_exc = cols
    failed = 0
    for k in range(k0, k1):
        row = k - k0
        us[0] = yp[col_a_tip]
        us[1] = yp[col_a_frf]
        us[2] = ya[col_strain]
        us[3] = ya[col_cell]
        us[4] = yp[col_dF]
        _copy(ys, ys_prev)
        _sensors_read(k, xs, us, sens_p, xs_n, ys, rng)
        _inject_sensors(k, faults, ys, ys_prev, sens_p)
        _tip_velocity(xs, sens_p, xs_n, ys)
        cin[0] = k
        cin[1] = ys[0]
        cin[2] = ys[1]
        cin[3] = ys[3]
        cin[4] = ys[4]
        cin[5] = 0.0
        cin[6] = yp[col_urel]
        cin[7] = yp[col_vrel]
        cstep(cstate.ctypes.data, cin.ctypes.data, faults.ctypes.data, faults.shape[0], cout.ctypes.data)
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
        log[row, 0] = F_exc
        ys[2] = cout[0]   # the C's integrator (the same bits as numba's)
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
        log[row, c] = 0.0
        log[row, c + 1] = 0.0
    return failed


def run_sil(loop, folder, freq_hz: float, amp_n: float, duration_s: float, *, seed=None, faults=None,
            cc=None) -> np.ndarray:
    """The log (ticks, len(loop.signals)) of an offline run of ``loop`` with the C export in
    ``folder`` as its controller (module docstring). ValueError for an export of another design."""
    cfg = loop.cfg
    seed = cfg.rt.seed if seed is None else seed
    st = initial_loop_state(loop, seed)
    m = read_manifest(folder)
    digest = design_hash(controller_record(loop, st))
    if m["design_hash"] != digest:
        raise ValueError(f"--controller c:{folder}: an export of another design ({m['design_hash'][:19]}...) than "
                         f"this loop's ({digest[:19]}...)")
    ctrl = build(folder, cc)
    cstep = ctrl.lib.ctrl_step_flat
    cstep.restype = None
    cstep.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p]
    init = ctrl.lib.ctrl_init_flat
    init.restype = None
    init.argtypes = [ctypes.c_void_p]
    cstate = np.zeros(-(-ctrl.state_bytes() // 8))
    init(cstate.ctypes.data)
    n = int(round(duration_s / cfg.dt_s))
    oi, ai = loop.plant.output_index(), actuator_output_index()
    exc_point = cfg.plant.excitation_point
    cols = (oi["u_rel"], oi["v_rel"], oi["abar_tip"], oi["abar_frf"], ai["F_strain_a"], ai["F_cell_a"], oi["dF_N1"],
            oi[f"w_{exc_point}"], oi[f"v_{exc_point}"])
    faults = no_faults() if faults is None else np.ascontiguousarray(faults, dtype=np.float64)
    sens = (st.xs, np.empty_like(st.xs), st.ys, np.empty_like(st.ys), np.empty_like(st.ys), np.zeros(5),
            loop.sensors, st.rng)
    act = (st.xa, np.empty_like(st.xa), st.ya, np.zeros(1), loop.actuator)
    plnt = (st.xp, np.empty_like(st.xp), st.yp, np.zeros(2), loop.plant.params, st.plant_work)
    shk = (cfg.shaker.on, st.xsh, np.empty_like(st.xsh), np.zeros(3), np.zeros(1), loop.shaker)
    log = np.empty((n, len(loop.signals)))
    failed = _sil_ticks(0, n, (cfg.dt_s, amp_n, 2 * math.pi * freq_hz), faults, sens, cstep, cstate, np.zeros(8),
                        np.zeros(N_OUTPUTS), act, plnt, shk, cols, log, np.zeros(2, np.int64))
    if failed:
        raise RuntimeError(f"{failed} plant steps failed")
    return log
