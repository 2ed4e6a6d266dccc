"""Coarsened interfaces of the 3-D reference (plant.fe3d, 57 contact points) against the 57 points:
node clustering by the bolts' contact footprints (plant.se_coarsen) and by k-means on the
coordinates (plant.superelement.coarsen).

    python -m benchmarks.se_footprint [--clusters 4,6,8,12,16,24] [--clusterings footprint,coordinates]
                                      [--no-hammer] [--mesh reference|coarse] [--json OUT.json]

Per point count and clustering: the static equilibrium at F_N1 = tracking.F_min_N (closed points,
closed points on the adaptive side x > the middle of the damper), the closed-stuck vertical bending
modes 2-5 there against the 57 points' (benchmarks.superelement_reference's linearisation), and the
hammer test at F_N1 = 100 N (plant.se_analysis.impulse: frequency and damping of modes 2-5) against
the 57 points' hammer test; the plant step's median wall time of the hammer run.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np
from benchmarks.entry import run_main, write_json

COARSE = {"interface_pitch_m": 0.04, "pitch_m": 0.05, "cutoff_hz": 4000.0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clusters", default="4,6,8,12,16,24")
    ap.add_argument("--clusterings", default="footprint,coordinates")
    ap.add_argument("--no-hammer", action="store_true")
    ap.add_argument("--mesh", choices=("reference", "coarse"), default="reference")
    ap.add_argument("--json", metavar="OUT.json")
    a = ap.parse_args(argv)
    from benchmarks.superelement_reference import _vertical_modes
    from frictionrt.plant import fe3d
    from frictionrt.plant.se_analysis import impulse
    from frictionrt.plant.se_coarsen import coarsen_structure
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.rt.common.config import Config
    cfg = Config()
    F_min, F_hammer = cfg.tracking.F_min_N, 100.0
    se, _ = fe3d.reference_superelement(cfg, **(COARSE if a.mesh == "coarse" else {}))
    x_mid = 0.5 * (se.contact_xyz[:, 0].min() + se.contact_xyz[:, 0].max())
    out: dict = {"load_avg_start": os.getloadavg()[0], "n_points": se.n_points, "rows": []}

    def measure(s, label):
        pl = build_se_plant(s, cfg, F_N1=F_min)
        g = pl.initial_state(F_min)[pl.state_slots()["g"]][0::1 + pl.params.nt]
        closed = g < 0
        r = {"label": label, "points": s.n_points, "closed": int(closed.sum()),
             "closed_adaptive_side": int((closed & (s.contact_xyz[:, 0] > x_mid)).sum()),
             "stuck_hz": _vertical_modes(pl, F_min, True)[1:5].round(3).tolist()}
        if not a.no_hammer:
            t = time.perf_counter()
            h = impulse(build_se_plant(s, cfg, F_N1=F_hammer), cfg, F_hammer, n_modes=4)
            r.update(hammer_f_hz=h["freq_hz"], hammer_zeta=h["damping_ratio"], hammer_s=round(time.perf_counter() - t, 1),
                     load_avg=os.getloadavg()[0])
        return r

    ref = measure(se, f"{se.n_points} points")
    out["reference"] = ref
    print(f"{se.n_points} points: closed at {F_min:g} N {ref['closed']} ({ref['closed_adaptive_side']} adaptive side), "
          f"stuck {ref['stuck_hz']} Hz" + ("" if a.no_hammer else
                                            f", hammer {ref['hammer_f_hz']} Hz, zeta {ref['hammer_zeta']} ({ref['hammer_s']} s)"),
          flush=True)
    for n in (int(c) for c in a.clusters.split(",")):
        for how in a.clusterings.split(","):
            try:
                r = measure(coarsen_structure(se, n, cfg, how), how)
            except (RuntimeError, ValueError) as e:
                print(f"{n:>3} {how:>11}: {e}", flush=True)
                out["rows"].append({"clusters": n, "label": how, "error": str(e)})
                continue
            r["clusters"] = n
            r["stuck_err_pct"] = (100 * (np.array(r["stuck_hz"]) / ref["stuck_hz"] - 1)).round(2).tolist()
            line = (f"{n:>3} {how:>11}: closed {r['closed']:>2} ({r['closed_adaptive_side']} adaptive side), "
                    f"stuck modes 2-5 {r['stuck_err_pct']} %")
            if not a.no_hammer:
                r["hammer_f_err_pct"] = (100 * (np.array(r["hammer_f_hz"]) / ref["hammer_f_hz"] - 1)).round(2).tolist()
                r["hammer_zeta_ratio"] = (np.array(r["hammer_zeta"]) / ref["hammer_zeta"]).round(3).tolist()
                line += (f"; hammer f {r['hammer_f_err_pct']} %, zeta / zeta_57 {r['hammer_zeta_ratio']} "
                         f"({r['hammer_s']} s, load {r['load_avg']:.1f})")
            print(line, flush=True)
            out["rows"].append(r)
    out["load_avg_end"] = os.getloadavg()[0]
    write_json(a.json, out)
    return 0


if __name__ == "__main__":
    run_main(main)
