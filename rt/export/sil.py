"""Software in the loop: the compiled C export as the controller of the numba loop
(``frictionrt simulate --controller c:DIR``).

``CController(loop, folder, seed)`` is a controller for ``frictionrt.rt.loop.driver.run(..., controller=)``:
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
import shutil
import tempfile
import weakref
from pathlib import Path

import numba
import numpy as np

from frictionrt.rt.common.clock import CLK_TICKS
from frictionrt.rt.export.cbuild import N_OUTPUTS, OUTPUTS, build, load
from frictionrt.rt.export.generate import check_design, read_manifest, require_double
from frictionrt.rt.export.record import TIP_SLOTS, controller_record, design_hash
from frictionrt.rt.loop.build import controller_stages, initial_loop_state
from frictionrt.rt.loop.driver import run
from frictionrt.rt.loop.tick import _put, _tick_begin, _tick_done, _tick_log, _tick_plant

STATE_PARTS = ("xs", "x_est", "xl", "xq", "xf", "sv")
"""ctrl_state's members in order (frictionrt_ctrl.h; ctrl_batch.c ``ctrl_state_offsets``): the tip
integrator's slots, the estimator's state (xe or xo), RT1, prefilter, PID, supervisor."""
_F_SET, _V_CMD = OUTPUTS.index("F_set"), OUTPUTS.index("V_cmd")   # the law's, the tracking's first output


@numba.njit(cache=True, nogil=True, _nrt=False)
def _sil_ticks(k0, k1, exc, pace, faults, sens, cstep, ctl, act, plnt, shk, cols, log, kf, sync):
    """Ticks k0 <= k < k1 of the loop (``frictionrt.rt.loop.tick._run_ticks``, untimed: its ``_tick_begin``,
    ``_tick_plant``, ``_tick_log``, ``_tick_done``) with the C controller cstep
    (``ctrl_step_flat``) in place of ``_controller_tick``; ctl = (its state buffer, input (8,),
    output (13,)). Log row (k - k0) mod len(log) receives the tick's signals. kf: the key frames
    (``_run_ticks``); before one is taken the C's state is copied into the loop's arrays it is
    taken from, sync = (the loop's arrays in ``STATE_PARTS`` order but the tip integrator's, their
    offsets in ctrl_state, yl, yf). Returns failed plant solves. RT-safe."""
    paced, period_ns, clk, ts = pace[1], pace[2], pace[4], pace[5]
    cstate, cin, cout = ctl
    ys, yp = sens[2], plnt[2]
    dsts, offs, yl, yf = sync
    failed = 0
    for k in range(k0, k1):
        if kf[0] > 0 and k % kf[0] == 0:   # the key frame holds the C's state
            j = 0
            for d in dsts:
                for i in range(d.shape[0]):
                    d[i] = cstate[offs[j] + i]
                j += 1
            if k > k0:
                yl[0] = cout[_F_SET]
                yl[1] = cout[_F_SET + 1]
                yf[0] = cout[_V_CMD]
                yf[1] = cout[_V_CMD + 1]
        # 1 sensors, injected sensor faults, the numba integrator (its state advances as the loop's)
        row, t_start, late = _tick_begin(k, k0, pace, faults, sens, act, plnt, cols, log, kf)
        if row < 0:
            break
        # 2-4 the C controller on the ADC readings (it integrates a_tip_meas itself)
        cin[0] = k
        cin[1] = ys[0]
        cin[2] = ys[1]
        cin[3] = ys[3]
        cin[4] = ys[4]
        cin[6] = yp[cols[0]]   # u_rel, v_rel: the oracle's test build reads them
        cin[7] = yp[cols[1]]
        cstep(cstate.ctypes.data, cin.ctypes.data, faults.ctypes.data, faults.shape[0], cout.ctypes.data)
        # 5 actuator on the C's V_cmd, 5s shaker, 6 plant
        F_exc, iters, t5 = _tick_plant(k, cout[8], exc, faults, act, plnt, shk, cols, False, ts)
        if iters < 0:
            failed += 1
        # 7 log: the readings with the C's v_tip_meas, the C's outputs, actuator, plant
        log[row, 0] = F_exc
        ys[2] = cout[0]
        c = _put(log, row, 1, ys)
        for j in range(1, cout.shape[0]):
            log[row, c + j - 1] = cout[j]
        c += cout.shape[0] - 1
        t_end = _tick_log(log, row, c, t_start, late, sens, act, plnt, shk, ts)
        # the overrun flag the C's supervisor reads next tick
        cin[5] = 1.0 if _tick_done(clk, paced, period_ns, t_end) else 0.0
    return failed


class CController:
    """The C export in ``folder`` as the controller of runs of ``loop`` (``frictionrt.rt.loop.driver.run(...,
    controller=)``), checked against the design of ``loop`` started at rest with ``seed``.
    ValueError for a folder that is no export, an export of another design (both hashes named),
    a missing compiler.

    The C's state (ctrl_state) is the run's: before its ticks it is loaded from the run's
    controller states (``frictionrt.rt.loop.build.controller_stages``: estimator, RT1, prefilter, PID,
    supervisor; the tip integrator's slots of the sensors' state), after them it is stored back,
    with the law's and the force tracking's last outputs (yl, yf), so that ``Run.final`` is the
    numba controller's and a run continued from it, with either controller, is the same. One
    object serves one run at a time.

    It pickles (``frf``'s worker processes, dask): ctypes objects do not, so a copy loads the
    library this object built, by its path (kept until this object is gone), or, where that path
    does not exist (another machine), builds the export in ``folder`` again; either must give the
    same design hash."""

    def __init__(self, loop, folder, seed: int, cc=None):
        folder = Path(folder)
        m = read_manifest(folder)
        require_double(m, f"--controller c:{folder}")
        digest = design_hash(controller_record(loop, initial_loop_state(loop, seed)))
        check_design(m, digest, loop, f"--controller c:{folder}", "this run's")
        self.folder, self.cc, self.design_hash = folder, cc, digest
        self.observe = loop.observes
        work = tempfile.mkdtemp(prefix="frictionrt-sil-")   # the library stays for the copies to load
        weakref.finalize(self, shutil.rmtree, work, True)
        self._link(build(folder, cc, workdir=work))
        st = initial_loop_state(loop, seed)
        sizes = [len(x) for x in self._parts((st.xs,), *controller_stages(loop, st))]
        if [s.stop - s.start for s in self.slices] != sizes or 8 * len(self.state) != self.build.state_bytes():
            raise ValueError(f"--controller c:{folder}: its ctrl_state ({', '.join(STATE_PARTS)}: "
                             f"{[s.stop - s.start for s in self.slices]} doubles) is not this loop's ({sizes}); "
                             "export it again")

    def _link(self, ctrl) -> None:
        """Set up the calls into the loaded build ``ctrl`` (``frictionrt.rt.export.cbuild.Controller``) and
        the buffers it steps on."""
        self.build = ctrl
        lib = ctrl.lib
        self.cstep = lib.ctrl_step_flat
        self.cstep.restype = None
        self.cstep.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p]
        try:
            offsets = lib.ctrl_state_offsets
        except AttributeError:
            raise ValueError(f"--controller c:{self.folder}: no ctrl_state_offsets in its ctrl_batch.c (an export "
                             "of an older frictionrt): export it again") from None
        offsets.restype = None
        offsets.argtypes = [ctypes.c_void_p]
        off = np.zeros(len(STATE_PARTS) + 1, dtype=np.int64)
        offsets(off.ctypes.data)
        self.slices = [slice(int(a), int(b)) for a, b in zip(off[:-1], off[1:])]
        self.state = np.zeros(int(off[-1]))   # ctrl_state: doubles only
        self.ctl = (self.state, np.zeros(8), np.zeros(N_OUTPUTS))

    def __getstate__(self) -> dict:
        return {"folder": self.folder, "cc": self.cc, "design_hash": self.design_hash, "observe": self.observe,
                "library": str(self.build.path), "command": self.build.command}

    def __setstate__(self, d: dict) -> None:
        self.folder, self.cc, self.design_hash, self.observe = d["folder"], d["cc"], d["design_hash"], d["observe"]
        lib = Path(d["library"])
        ctrl = load(lib, d["command"]) if lib.is_file() else build(self.folder, self.cc)
        if ctrl.design_hash != self.design_hash:
            raise ValueError(f"--controller c:{self.folder}: the library {ctrl.path} is of design "
                             f"{ctrl.design_hash[:19]}..., not {self.design_hash[:19]}...: export it again")
        self._link(ctrl)

    def _parts(self, sens, est, law, sup, trk) -> list[np.ndarray]:
        """The loop's arrays (the stages' tuples as ``_run_ticks`` takes them) that ctrl_state
        holds, in its order (``STATE_PARTS``); views, so that assigning into them writes the
        loop's state."""
        return [sens[0][TIP_SLOTS], est[5] if self.observe else est[0], law[0], trk[0], trk[5], sup[0]]

    def __call__(self, k0, k1, exc, pace, faults, sens, est, law, sup, trk, act, plnt, shk, cols, log, kf) -> int:
        """Ticks k0 <= k < k1 (``frictionrt.rt.loop.tick._run_ticks``' arguments but force_col, observe and
        comp_ns) with the C controller, its state loaded from the loop's controller states and
        stored back after (class docstring). Returns the failed plant solves."""
        clk = pace[4]
        yl, yf = law[2], trk[7]
        parts = self._parts(sens, est, law, sup, trk)
        for sl, x in zip(self.slices, parts):
            self.state[sl] = x
        ticks = int(clk[CLK_TICKS])
        sync = (tuple(parts[1:]), np.array([sl.start for sl in self.slices[1:]], np.int64), yl, yf)
        failed = _sil_ticks(k0, k1, exc, pace, faults, sens, self.cstep, self.ctl, act, plnt, shk, cols, log, kf, sync)
        # the C's states back (the tip integrator's are the sensors' own: the numba integrator ran
        # beside the C's, the same bits), and the last tick's outputs the loop state keeps
        for sl, x in zip(self.slices[1:], parts[1:]):
            x[:] = self.state[sl]
        if int(clk[CLK_TICKS]) > ticks:
            cout = self.ctl[2]
            yl[:] = cout[_F_SET:_F_SET + len(yl)]
            yf[:] = cout[_V_CMD:_V_CMD + len(yf)]
        return failed


def run_sil(loop, folder, freq_hz: float, amp_n: float, duration_s: float, *, seed=None, faults=None,
            cc=None) -> np.ndarray:
    """The log (ticks, len(loop.signals)) of an offline run of ``loop`` with the C export in
    ``folder`` as its controller (``CController``)."""
    seed = loop.cfg.rt.seed if seed is None else seed
    return run(loop, freq_hz, amp_n, duration_s, seed=seed, faults=faults,
               controller=CController(loop, folder, seed, cc)).log
