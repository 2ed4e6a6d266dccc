"""Why a claim fails: the measured mechanism behind each failing cell of a reproduction
(``frictionrt reproduce``'s report; ``python -m benchmarks.claim_mechanisms`` on a saved one).

The cells that make C3 or C4 fail on an estimator of a report (text keys, as report.json has them):
for C3, the cells of a law that reduces fewer than two modes at every amplitude where its reduction
is above -0.5 dB; for C4, the cells at the smallest amplitude above +0.5 dB (rt.experiments.claims).
Each is run once more: the law, on that estimator, at the cell's peak frequency and amplitude for a
given duration, steady state over the last half:

* ``u0_um``: the RT1 amplitude u0 [um] (mean), and ``Kf_u0_over_Fmin`` = K_f u0 / F_min: below 1 the
  hysteresis law's setpoint K_f u0 (Eq. 3) saturates at F_min, so the law is the passive law;
* ``F_set_mean_n``, ``F_N1_mean_n`` [N], ``at_F_max``: the share of ticks with F_set at F_max;
* ``F_set_2f_n``, ``F_N1_2f_n``: the amplitudes [N] at twice the excitation frequency, the rate at
  which the Lyapunov law switches, and ``transmitted`` = F_N1_2f / F_set_2f: the share of the law's
  switching the force tracking, the output low-pass and the stack pass on to the screw (NaN where
  F_set's is below 1 N: the law holds its force);
* ``constant_clamp_peak``: the passive peak |H| [(m/s^2)/N] at a constant F_N1 equal to the law's
  mean F_N1, interpolated (linear in F_N1) in the report's baseline ``peaks_by_fn1``, beside the
  law's own peak: equal, the law acts as a constant clamp at its mean force.
"""
from __future__ import annotations

import numpy as np

from frictionrt.rt.experiments.claims import TOL_DB
from frictionrt.rt.experiments.stepsine import harmonics_of_columns
from frictionrt.rt.loop import Designs, build_loop, run


def failing_cells(by_est: dict) -> list[dict]:
    """[{estimator, claim, law, mode, amp}] of the C3 and C4 failures (module docstring), as text keys."""
    cells = []
    for est, v in by_est.items():
        red = v["peak_change_db"]
        if not v["claims"]["C3"]["holds"]:
            for law, modes in v["claims"]["C3"]["numbers"]["modes_reduced"].items():
                if len(modes) < v["claims"]["C3"]["numbers"]["min_modes"]:
                    cells += [{"estimator": est, "claim": "C3", "law": law, "mode": m, "amp": a}
                              for m, by_amp in red[law].items() for a, x in by_amp.items() if x > -TOL_DB]
        if not v["claims"]["C4"]["holds"]:
            amp = f"{v['claims']['C4']['numbers']['amplitude_n']:g}"
            cells += [{"estimator": est, "claim": "C4", "law": law, "mode": m, "amp": amp}
                      for law, by_mode in red.items() for m, by_amp in by_mode.items() if by_amp[amp] > TOL_DB]
    return cells


def constant_clamp_peak(peaks_by_fn1: dict, fn1_n: float) -> float:
    """The baseline's passive peak at constant F_N1 = fn1_n [N], linear between the forces tried."""
    f = np.array([float(k) for k in peaks_by_fn1])
    order = np.argsort(f)
    return float(np.interp(fn1_n, f[order], np.array(list(peaks_by_fn1.values()), dtype=float)[order]))


def mechanism(cfg, designs: Designs, cell: dict, report: dict, duration_s: float) -> dict:
    """One cell's closed-loop run at its peak (module docstring)."""
    v = report["by_estimator"][cell["estimator"]]
    pk = v["peaks"][cell["law"]][cell["mode"]][cell["amp"]]
    f, amp = pk["f_hz"], float(cell["amp"])
    loop = build_loop(cfg, cell["law"], cell["estimator"], designs=designs)
    r = run(loop, f, amp, duration_s)
    dt, t = cfg.dt_s, cfg.tracking
    n = len(r.log) // 2
    X = np.column_stack([r.signal(s)[-n:] for s in ("F_set", "F_N1")])
    F_set_2f, F_N1_2f = (abs(h.X[1]) for h in harmonics_of_columns(X, f, dt, 2, k0=len(r.log) - n))
    u0 = float(np.mean(r.signal("u0")[-n:]))
    F_N1 = float(np.mean(r.signal("F_N1")[-n:]))
    best = report["best_passive_fn1"][cell["mode"]][cell["amp"]]
    reduction = v["peak_change_db"][cell["law"]][cell["mode"]][cell["amp"]]
    return cell | {"f_hz": f, "peak": pk["H_abs"], "reduction_db": reduction,
                   "u0_um": 1e6 * u0, "Kf_u0_over_Fmin": t.K_f * u0 / t.F_min_N,
                   "F_set_mean_n": float(np.mean(X[:, 0])), "F_N1_mean_n": F_N1,
                   "at_F_max": float(np.mean(X[:, 0] >= t.F_max_N * (1 - 1e-9))),
                   "F_set_2f_n": float(F_set_2f), "F_N1_2f_n": float(F_N1_2f),
                   "transmitted": float(F_N1_2f / F_set_2f) if F_set_2f >= 1.0 else float("nan"),
                   "constant_clamp_peak": constant_clamp_peak(best["peaks_by_fn1"], F_N1)}
