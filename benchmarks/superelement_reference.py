"""The 3-D reference of the paper's structure (plant.fe3d) against its full FE model and against the
2-D beam plant, and the imported plant's step cost against the number of contact points.

    python -m benchmarks.superelement_reference [--interface-pitch M] [--width-elems N]
        [--clusters 4,8,16,32] [--steps N] [--json OUT.json] [--save REF.npz]

1. Reduced (Craig-Bampton) vs full hexahedral model, every contact point stuck: lowest 8 modes.
2. The 2-D beam plant (build_plant, default configuration) vs the 3-D reduced model: vertical
   bending modes (the 3-D modes whose tip moves more in z than in y), stuck at every point and
   stuck at the points closed at F_N1 = tracking.F_min_N.
3. The step's median wall time [us] vs contact points (the interface coarsened by node clustering),
   2-D friction (circular limit) and 1-D friction (the second tangential row dropped), a 5 N sine at
   200 Hz for --steps steps; the machine's load average beside it.
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from benchmarks.entry import run_main, write_json


def _vertical_modes(plant, F_N1, closed_only):
    from frictionrt.plant.se_analysis import _stuck_modes
    p = plant.params
    if closed_only:
        f, V, _ = _stuck_modes(plant, F_N1)
    else:
        import scipy.linalg as sla
        d = 1 + p.nt
        kc = np.zeros(p.G.shape[0])
        kc[0::d] = p.k_n
        for a in range(1, d):
            kc[a::d] = p.k_t
        lam, V = sla.eigh(np.diag(p.omega2) + (p.G.T * kc) @ p.G)
        f = np.sqrt(np.maximum(lam, 0)) / (2 * np.pi)
    names = plant.se.sensor_names
    z = np.abs(p.S[names.index("tip")] @ V)
    y = np.abs(p.S[names.index("tip_y")] @ V)
    return f[(z > y) & (f > 1.0)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--interface-pitch", type=float, default=0.02, help="element length over the damper [m]")
    ap.add_argument("--pitch", type=float, default=0.02, help="element length elsewhere [m]")
    ap.add_argument("--width-elems", type=int, default=1, help="elements across the width")
    ap.add_argument("--cutoff", type=float, default=4000.0, help="Craig-Bampton cut-off [Hz]")
    ap.add_argument("--clusters", default="2,4,8,16,32", help="contact point counts for the cost sweep")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--no-full", action="store_true", help="skip the full FE eigenvalue check")
    ap.add_argument("--fine-steps", type=int, default=None, help="steps of the run at every contact point (default --steps)")
    ap.add_argument("--dims", default="2,1", help="tangential directions of the cost sweep (2: circular limit, 1)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--save", default=None, help="write the reduced superelement to this .npz")
    a = ap.parse_args(argv)

    from frictionrt.plant import fe3d
    from frictionrt.plant import superelement as S
    from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
    from frictionrt.plant.se_analysis import simulate
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.plant.se_plant import stuck_frequencies_hz as se_stuck
    from frictionrt.rt.common.config import Config
    cfg = Config()
    out: dict = {"load_avg": os.getloadavg()}
    t0 = time.perf_counter()
    se, info = fe3d.reference_superelement(cfg, interface_pitch_m=a.interface_pitch, pitch_m=a.pitch,
                                           width_elems=a.width_elems, cutoff_hz=a.cutoff)
    out.update(n_full=info["n_full"], n_reduced=info["n_reduced"], n_points=info["n_points"],
               build_s=round(time.perf_counter() - t0, 1))
    print(f"3-D reference: {info['n_full']} DOFs, {info['n_points']} contact points, reduced to {info['n_reduced']} "
          f"({info['n_boundary']} boundary DOFs + {len(info['fixed_interface_hz'])} modes), {out['build_s']} s")
    if a.save:
        S.save(se, a.save)
    if a.json:   # what is known so far, in case a later stage is stopped
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)
    plant = build_se_plant(se, cfg)
    itf = cfg.plant.interface
    f_red = se_stuck(plant, closed_only=False)[:8]
    out["reduced_stuck_hz"] = f_red.round(3).tolist()
    if not a.no_full:
        full, finfo = fe3d.reference_superelement(cfg, interface_pitch_m=a.interface_pitch, pitch_m=a.pitch,
                                                  width_elems=a.width_elems, reduce=False)
        f_full = fe3d.full_stuck_frequencies_hz(finfo, full, itf.k_n_area * se.contact_area,
                                                itf.k_t_area * se.contact_area)
        out["full_stuck_hz"] = f_full.round(3).tolist()
        out["reduction_error_pct"] = (100 * (f_red / f_full - 1)).round(4).tolist()
        print("1. stuck, all points    full [Hz]  reduced [Hz]  error [%]")
        for i, (ff, fr) in enumerate(zip(f_full, f_red)):
            print(f"   mode {i + 1:>2}          {ff:>10.2f}  {fr:>12.2f}  {100 * (fr / ff - 1):>9.4f}")
    # --- 2-D against 3-D
    m2 = build_plant(cfg)
    F_min = cfg.tracking.F_min_N
    rows = []
    f2_all = stuck_frequencies_hz(m2)
    f2_min = stuck_frequencies_hz(m2, preloaded_pairs(m2, F_min))
    f3_all = _vertical_modes(plant, F_min, closed_only=False)
    f3_min = _vertical_modes(plant, F_min, closed_only=True)
    print(f"2. vertical bending, 2-D beam plant vs 3-D ({info['n_points']} points): stuck everywhere | stuck where closed at F_min = {F_min:g} N")
    for k in range(1, 5):     # modes 2..5
        r = {"mode": k + 1, "2d_all": float(f2_all[k]), "3d_all": float(f3_all[k]),
             "2d_fmin": float(f2_min[k]), "3d_fmin": float(f3_min[k])}
        rows.append(r)
        print(f"   mode {k + 1}: 2-D {r['2d_all']:8.2f} 3-D {r['3d_all']:8.2f} ({100 * (r['2d_all'] / r['3d_all'] - 1):+6.2f} %)"
              f"  |  2-D {r['2d_fmin']:8.2f} 3-D {r['3d_fmin']:8.2f} ({100 * (r['2d_fmin'] / r['3d_fmin'] - 1):+6.2f} %)")
    out["two_d_vs_three_d"] = rows
    # --- cost vs points
    cost = []
    dur = a.steps * cfg.dt_s
    fine_steps = a.steps if a.fine_steps is None else a.fine_steps
    for k in [int(c) for c in a.clusters.split(",") if c] + [se.n_points]:
        k = min(k, se.n_points)
        sek = S.coarsen(se, k)
        steps = fine_steps if k == se.n_points else a.steps
        for nt in [int(x) for x in a.dims.split(",")]:
            s = sek if nt == 2 else sek.with_(contact_rows=np.ascontiguousarray(sek.contact_rows[:, :2]))
            try:
                pl = build_se_plant(s, cfg)
            except RuntimeError as e:   # e.g. 1-D friction leaves a coarse interface free across the width
                print(f"3. {k:>4} points, {nt}-D friction: {e}")
                cost.append({"points": k, "friction_dims": nt, "error": str(e)})
                continue
            f3k = _vertical_modes(pl, F_min, closed_only=True)
            err = (100 * (f3k[1:5] / f3_min[1:5] - 1)).round(3).tolist() if nt == 2 else None
            simulate(pl, cfg, 200.0, 5.0, min(steps, 20) * cfg.dt_s, pl.F_N1_initial)   # compile, warm
            r = simulate(pl, cfg, 200.0, 5.0, steps * cfg.dt_s, pl.F_N1_initial)
            cost.append({"points": k, "friction_dims": nt, "n": pl.n, "steps": steps,
                         "median_us": round(r["step_median_us"], 2),
                         "p99_us": round(r["step_p99_us"], 2), "newton_iter_mean": round(r["newton_iter_mean"], 2),
                         "load_avg_1min": os.getloadavg()[0], "closed_stuck_err_pct_modes_2_5": err})
            if err is not None:
                print(f"   {k:>4} points: closed-stuck modes 2-5 against every point: {err} %")
            print(f"3. {k:>4} points, {nt}-D friction, {pl.n} modes: median {r['step_median_us']:9.2f} us, "
                  f"p99 {r['step_p99_us']:9.2f} us, Newton {r['newton_iter_mean']:.2f} (load {os.getloadavg()[0]:.1f})")
    out["cost"] = cost
    write_json(a.json, out)
    return 0


if __name__ == "__main__":
    run_main(main)
