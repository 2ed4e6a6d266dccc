"""The numba controller over a stream of readings, as the exported C runs it (ctrl_batch.c
``ctrl_run``): the tip integrator (``frictionrt.plant.sensors._tip_velocity``) and
``frictionrt.rt.loop.tick._controller_tick`` / ``_controller_done``, each tick timed. ``bench
controller`` times it; the golden vectors of an export are its outputs.
"""
from __future__ import annotations

import numba
import numpy as np

from frictionrt.plant.sensors import SENSOR_OUTPUTS, _tip_velocity
from frictionrt.rt.common.clock import _now_ns
from frictionrt.rt.loop.build import controller_stages
from frictionrt.rt.loop.tick import _controller_done, _controller_tick

SENSORS = tuple(n for n, _ in SENSOR_OUTPUTS)
READINGS = ("a_tip_meas", "a_frf_meas", "F_strain", "F_cell")


@numba.njit(cache=True, nogil=True, _nrt=False)
def _timed_ticks(ks, sens, uv, out, ns, force_col, observe, faults, ts, yc, tip, est, law, sup, trk):
    """The controller of each tick ks[i] on the readings sens[i] (``SENSOR_OUTPUTS``; v_tip_meas
    written by the integrator), the oracle's uv[i]; outputs (v_tip_meas, ``COMMANDED``) into
    out[i], the tick's time [ns] into ns[i]. tip = (xs, xs_n, sensor params). RT-safe."""
    xs, xs_n, sens_p = tip
    for i in range(ks.shape[0]):
        t0 = _now_ns(ts)
        ys = sens[i]
        _tip_velocity(xs, sens_p, xs_n, ys)
        xs[6] = xs_n[6]
        xs[7] = xs_n[7]
        _controller_tick(ks[i], ys, yc, uv[i, 0], uv[i, 1], force_col, observe, faults, False, ts, est, law, sup, trk)
        out[i, 0] = ys[2]
        _controller_done(out, i, 1, observe, est, law, sup, trk)
        ns[i] = _now_ns(ts) - t0


def closed_loop_readings(loop, n: int, freq_hz: float | None = None, amp_N: float | None = None):
    """(k, readings (n, 5) in ``SENSOR_OUTPUTS`` order, uv (n, 2) the plant's u_rel, v_rel of the
    tick before) of a closed-loop run of n ticks at freq_hz [Hz], amp_N [N] (default: the
    budget's excitation)."""
    from frictionrt.rt.loop.budget import EXC_AMP_N, EXC_FREQ_HZ
    from frictionrt.rt.loop.driver import run
    r = run(loop, EXC_FREQ_HZ if freq_hz is None else freq_hz, EXC_AMP_N if amp_N is None else amp_N,
            n * loop.cfg.dt_s)
    sens = np.ascontiguousarray(r.log[:, [loop.column(c) for c in SENSORS]])
    uv = np.zeros((len(sens), 2))
    uv[1:] = r.log[:-1, [loop.column("u_rel"), loop.column("v_rel")]]
    return np.arange(len(sens), dtype=np.int64), sens, uv


def numba_outputs(loop, st, k, sens, uv):
    """(outputs (n, 13) in ctrl_outputs order, ns (n,) each tick's time [ns]) of the numba
    controller of ``loop`` from a copy of ``st`` over ticks k, readings sens (n, 5) and the
    oracle's uv (n, 2), without faults or overruns."""
    st = st.copy()
    si = {nm: i for i, nm in enumerate(SENSORS)}
    force_col = si["F_strain" if loop.force_sensor == "strain" else "F_cell"]
    est, law_, sup, trk = controller_stages(loop, st)
    out = np.full((len(k), 13), np.nan)
    ns = np.zeros(len(k), dtype=np.int64)
    _timed_ticks(k, sens.copy(), uv, out, ns, force_col, loop.observes, np.zeros((0, 5)),
                 np.zeros(2, np.int64), np.empty(len(SENSORS)), (st.xs, st.xs.copy(), loop.sensors), est, law_, sup, trk)
    return out, ns
