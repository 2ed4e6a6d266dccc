"""The figures of a finished run (``summary``: what ``frictionrt simulate`` prints) and the
first-harmonic amplitude they rest on."""
from __future__ import annotations

import numpy as np

from frictionrt.observer.accuracy import (at_estimate_instant, band_limited_truth, lyapunov_command_error, nrmse,
                                          sign_error_rate)
from frictionrt.rt.loop.driver import Run
from frictionrt.rt.loop.supervisor import F_START


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
    from its digest (``frictionrt.rt.loop.digest``), the last-20 % figures from the rows held (docs/loop.md)."""
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
    } | _supervisor_summary(r) | (_estimation_errors(r) if r.loop.estimator != "oracle" else {}) \
        | ({"realtime": r.realtime} if r.realtime is not None else {})


def _supervisor_summary(r: Run) -> dict:
    """``trips``: every latched fault (code, name, tick, recovered_tick); ``faults``: per injected
    fault its kind, sensor, tick, and the code, detected_tick, passive_tick the supervisor logged
    (``frictionrt.rt.loop.faults.outcome``). Ticks are absolute."""
    from frictionrt.rt.loop.faults import outcome, trips
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
    rows held: a ring run's last ticks); the |v_rel|-weighted sign error rate of v_rel_hat and,
    under the Lyapunov law, the rms and mean error [N] of its command F* from the estimate against
    F* from the truth (observer.accuracy), every one with the truth at the estimate's instant
    (``observer.accuracy.at_estimate_instant``)."""
    cfg = r.loop.cfg
    dt, f_c = cfg.dt_s, cfg.observer.oracle_bandwidth_hz
    v_true = band_limited_truth(r.signal("v_rel"), dt, f_c)
    u_true = band_limited_truth(r.signal("u_rel"), dt, f_c)
    tail = _tail(r)
    u0_true = float(np.mean(0.5 * np.pi * np.abs(u_true[tail])))
    u0_hat = float(np.mean(r.signal("u0")[tail]))
    # the estimate of row k + 1 with the truth of row k: both at t_k+1 (observer.accuracy)
    v_hat, v_true = at_estimate_instant(r.signal("v_rel_hat"), v_true)
    u_hat, u_true_k = at_estimate_instant(r.signal("u_rel_hat"), u_true)
    out = {"v_rel_nrmse": nrmse(v_hat, v_true), "u_rel_nrmse": nrmse(u_hat, u_true_k),
           "u0_rel_error": (u0_hat - u0_true) / u0_true if u0_true > 0 else float("nan"),
           "v_rel_sign_error": sign_error_rate(v_hat, v_true)}
    if r.loop.law == "lyapunov":
        t = cfg.tracking
        rms, mean = lyapunov_command_error(v_hat, v_true, t.F_min_N, t.F_max_N, t.eps_m_s)
        out |= {"fstar_rms_error_n": rms, "fstar_mean_error_n": mean}
    return out
