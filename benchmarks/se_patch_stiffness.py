"""The coarsened interfaces against the paper-size one (585 points) when stuck: the footprint groups
as they were ("footprint") and with the held patches' normal stiffness kept ("footprint-patches",
plant.se_coarsen.patch_stiffness).

    python -m benchmarks.se_patch_stiffness --cache REF585.npz [--clusters 6,8,16] [--fine FINE.npz] [--json OUT.json]

--cache: the reference written by ``python -m benchmarks.se_fine_reference --cache REF585.npz``.
Per interface: the vertical bending modes 2-5 stuck where closed at tracking.F_min_N and at
tracking.F_max_N (one static solve each), and the two limits: the lowest 8 modes with every point
stuck, and with every point open (the structure's own modes; a kept patch stiffness stays there).
Each against the 585 points'. The footprint states (which point closes at which force) are solved
once on the fine plant and shared by every grouping. Run with OPENBLAS_NUM_THREADS=1 on a shared
machine. About 10 min of CPU.
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from benchmarks.entry import run_main, write_json

N_LIMIT = 8


def footprint_closed_of(plant, cfg) -> np.ndarray:
    """plant.se_coarsen.footprint_closed from an already built plant (its modal coordinates, the
    adaptive bolt's spring taken out again: the bolt a force)."""
    from frictionrt.plant.se_coarsen import footprint_levels_n
    from frictionrt.plant.se_plant import static_equilibrium
    p = plant.params
    K_free = np.diag(p.omega2) - p.bolt_k * np.outer(p.bolt_row, p.bolt_row)
    p0 = p._replace(f_const=p.f_const - p.bolt_row * p.bolt_k * p.bolt_ref)
    levels = footprint_levels_n(cfg)
    d = 1 + p.nt
    out = np.zeros((len(levels), plant.n_points), bool)
    for i in range(len(levels)):
        _, _, g = static_equilibrium(p0, levels[i], K=K_free)
        out[i] = g[0::d] < 0.0
    return out


def summary(plant, cfg) -> dict:
    """Stuck modes 2-5 at F_min and F_max (closed points), the stuck and the open limits [Hz]."""
    from benchmarks.se_fine_reference import vertical_modes
    from frictionrt.plant.se_plant import stuck_frequencies_hz
    out = {}
    for key, F in (("F_min", cfg.tracking.F_min_N), ("F_max", cfg.tracking.F_max_N)):
        f, n = vertical_modes(plant, F)
        out[key] = {"hz": f.round(3).tolist(), "closed": n}
    out["stuck_all_hz"] = stuck_frequencies_hz(plant, closed_only=False)[:N_LIMIT].round(3).tolist()
    f_open = plant.omega[plant.omega > 0] / (2 * np.pi)
    out["open_hz"] = np.sort(f_open)[:N_LIMIT].round(3).tolist()
    return out


def errors(got: dict, ref: dict) -> dict:
    pct = lambda a, b: (100 * (np.array(a) / np.array(b) - 1)).round(2).tolist()
    return {"F_min_pct": pct(got["F_min"]["hz"], ref["F_min"]["hz"]), "F_max_pct": pct(got["F_max"]["hz"], ref["F_max"]["hz"]),
            "stuck_all_pct": pct(got["stuck_all_hz"], ref["stuck_all_hz"]), "open_pct": pct(got["open_hz"], ref["open_hz"])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", required=True, help="the 585-point reference (.npz, benchmarks.se_fine_reference)")
    ap.add_argument("--clusters", default="6,8,16")
    ap.add_argument("--clusterings", default="footprint,footprint-patches")
    ap.add_argument("--fine", metavar="FINE.npz", help="the fine interface's footprint states and modes: read if "
                    "present, else written (they take most of the run's time)")
    ap.add_argument("--json", metavar="OUT.json")
    a = ap.parse_args(argv)
    from frictionrt.plant import superelement as S
    from frictionrt.plant.se_coarsen import coarsen_structure
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.rt.common.config import Config
    if not os.path.exists(a.cache):
        print(f"--cache {a.cache}: no such file; build it with python -m benchmarks.se_fine_reference --cache {a.cache}")
        return 2
    cfg = Config()
    t0 = time.perf_counter()
    se = S.load(a.cache)
    if a.fine and os.path.exists(a.fine):
        z = np.load(a.fine)
        closed, ref = z["closed"], json.loads(str(z["reference"]))
    else:
        plant = build_se_plant(se, cfg)
        closed = footprint_closed_of(plant, cfg)
        ref = summary(plant, cfg)
        if a.fine:
            np.savez(a.fine, closed=closed, reference=json.dumps(ref))
    out = {"load_avg_start": os.getloadavg()[0], "points": se.n_points, "reference": ref,
           "closed_per_level": closed.sum(axis=1).tolist(), "held": int(closed.all(axis=0).sum()), "rows": []}
    print(f"{se.n_points} points ({time.perf_counter() - t0:.0f} s): closed at the footprint levels "
          f"{out['closed_per_level']}, at every level {out['held']}; stuck modes 2-5 at F_min {ref['F_min']['hz']} Hz "
          f"({ref['F_min']['closed']} closed), at F_max {ref['F_max']['hz']} Hz ({ref['F_max']['closed']} closed)", flush=True)
    print(f"  every point stuck {ref['stuck_all_hz']} Hz; open {ref['open_hz']} Hz", flush=True)
    for c in (int(x) for x in a.clusters.split(",") if x):
        for cl in a.clusterings.split(","):
            t0 = time.perf_counter()
            sc = coarsen_structure(se, c, cfg, cl, closed=closed)
            s = summary(build_se_plant(sc, cfg), cfg)
            row = {"groups": c, "clustering": cl, "source": sc.source, "build_s": round(time.perf_counter() - t0, 1), **s,
                   **errors(s, ref)}
            out["rows"].append(row)
            print(f"{c:>3} {cl:<18} closed {s['F_min']['closed']:>2} | modes 2-5 at F_min {row['F_min_pct']} %, at F_max "
                  f"{row['F_max_pct']} % | every point stuck {row['stuck_all_pct']} %, open {row['open_pct']} % "
                  f"({row['build_s']} s)", flush=True)
            write_json(a.json, out)
    out["load_avg_end"] = os.getloadavg()[0]
    write_json(a.json, out)
    return 0


if __name__ == "__main__":
    run_main(main)
