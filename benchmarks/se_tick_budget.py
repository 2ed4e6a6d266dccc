"""The whole tick's cost on an imported structure against its number of contact points, A/B against
the built-in 2-D beams in the same run.

    python -m benchmarks.se_tick_budget [--clusters 2,3,4,6,8,12,16,24,32,0] [--dims 2,1]
        [--clustering footprint|coordinates] [--steps 4200] [--fine-steps 1050] [--reps 3]
        [--law lyapunov] [--estimator observer] [--paced-s 0] [--paced-reps 2] [--set KEY=VALUE] [--json OUT]

The 3-D reference (plant.fe3d, 57 contact points) coarsened by --clustering (plant.se_coarsen,
default the bolts' footprints; 0: the 57 points as built), with 2-D friction (circular limit) and 1-D friction
(the second tangential row dropped before the coarsening). Per case the closed loop of --law on
--estimator (the observer designed from the superelement) runs at the tick budget's excitation
(rt.loop.budget: 5 N at 223.6 Hz, stick-slip every cycle) with per-stage timing
(``run(..., timing=True)``): the whole tick's and the plant stage's median [us]; the built-in loop
(same law and estimator) is run before each repetition of the case, alternating, and the load
average is kept beside each row. --fine-steps: the steps of cases above 24 points. The offline runs'
tick times are pooled over the repetitions for the tails (median, p99, p99.9, max). --paced-s: the
paced run (absolute deadlines at dt, as ``frictionrt budget``) of each loop, alternating, --paced-reps
times: its missed deadlines (overruns), lateness and tick median, and the ticks the supervisor held
passive (a burst of overruns latches the fault overrun_burst: the law stops, F_N1 goes to F_min,
and the ticks after it are the passive loop's).
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np
from benchmarks.entry import run_main, write_json

BUDGET_US = 8.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clusters", default="2,3,4,6,8,12,16,24,32,0")
    ap.add_argument("--dims", default="2,1")
    ap.add_argument("--steps", type=int, default=4200)
    ap.add_argument("--fine-steps", type=int, default=1050)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--clustering", default="footprint")
    ap.add_argument("--law", default="lyapunov")
    ap.add_argument("--estimator", default="observer")
    ap.add_argument("--mesh", choices=("reference", "coarse"), default="reference")
    ap.add_argument("--paced-s", type=float, default=0.0, help="a paced run of this length per case and repetition "
                    "(A/B with the built-in loop): missed deadlines, as frictionrt budget")
    ap.add_argument("--paced-reps", type=int, default=2)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a configuration override for both loops (e.g. rt.priority=80, rt.cpu=1 for the paced runs)")
    ap.add_argument("--json", metavar="OUT.json")
    a = ap.parse_args(argv)
    from frictionrt.plant import fe3d
    from frictionrt.plant import superelement as S
    from frictionrt.plant.se_coarsen import coarsen_structure
    from frictionrt.rt.common.config import Config, with_sets
    from frictionrt.rt.loop import build_loop
    from frictionrt.rt.loop.budget import EXC_AMP_N, EXC_FREQ_HZ
    from frictionrt.rt.loop.build import COMPONENTS
    from frictionrt.rt.loop.driver import run
    from frictionrt.rt.loop.floor import tails_us
    from frictionrt.rt.loop.structure import structure_of
    from frictionrt.rt.loop.supervisor import FAULT_CODES
    cfg = with_sets(Config(), a.set)
    kw = {"interface_pitch_m": 0.04, "pitch_m": 0.05} if a.mesh == "coarse" else {}
    se, _ = fe3d.reference_superelement(cfg, **kw)
    i_plant = COMPONENTS.index("plant")

    ticks = {}   # (case, "A" | "B") -> list of the offline runs' tick times [ns], pooled for the tails

    def medians(loop, steps, key=None):
        r = run(loop, EXC_FREQ_HZ, EXC_AMP_N, steps * cfg.dt_s, timing=True)
        if key is not None:
            ticks.setdefault(key, []).append(np.asarray(r.signal("tick_ns"), dtype=float))
        return float(np.median(r.signal("tick_ns")) / 1e3), float(np.median(r.comp_ns[:, i_plant]) / 1e3)

    def tails(key):
        us = np.concatenate(ticks.pop(key)) / 1e3
        return {"median_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)),
                "p999_us": float(np.percentile(us, 99.9)), "max_us": float(us.max()), "ticks": int(us.size)}

    def paced(loop):
        p = run(loop, EXC_FREQ_HZ, EXC_AMP_N, a.paced_s, paced=True)
        late = p.signal("late_ns")
        n_p = len(late) + p.overruns
        passive = np.asarray(p.signal("passive")) > 0.5
        latched = np.asarray(p.signal("fault_latched"))
        first = int(np.argmax(passive)) if passive.any() else -1
        return {"passive_ticks": int(passive.sum()), "first_passive_tick": first,
                "fault": FAULT_CODES[int(latched[first])] if first >= 0 else "none",
                "ticks": int(len(late)), "overruns": int(p.overruns), "overrun_rate": p.overruns / n_p,
                "late": tails_us(late), "tick_median_us": float(np.median(p.signal("tick_ns")) / 1e3),
                "tick_p99_us": float(np.percentile(p.signal("tick_ns"), 99) / 1e3),
                "tick_p999_us": float(np.percentile(p.signal("tick_ns"), 99.9) / 1e3),
                "tick_max_us": float(np.max(p.signal("tick_ns")) / 1e3),
                "ticks_over_period": int(np.sum(p.signal("tick_ns") > cfg.dt_s * 1e9)),
                "wall_s": p.wall_ns / 1e9, "realtime": p.realtime}

    builtin = build_loop(cfg, a.law, a.estimator)
    run(builtin, EXC_FREQ_HZ, EXC_AMP_N, 0.01, timing=True)
    out = {"sets": a.set, "clustering": a.clustering, "law": a.law, "estimator": a.estimator, "budget_us": BUDGET_US, "points_full": se.n_points, "rows": []}
    print(f"whole tick and plant stage median [us], {a.law}/{a.estimator}, 5 N at {EXC_FREQ_HZ} Hz; "
          f"built-in 2-D beams in the same run (A/B)", flush=True)
    with tempfile.TemporaryDirectory() as d:
        for nt in (int(x) for x in a.dims.split(",")):
            base = se if nt == 2 else se.with_(contact_rows=np.ascontiguousarray(se.contact_rows[:, :2]))
            for c in (int(x) for x in a.clusters.split(",")):
                row = {"friction_dims": nt, "clusters": c, "points": c or se.n_points}
                try:
                    s = coarsen_structure(base, c, cfg, a.clustering) if c else base
                    f = S.save(s, os.path.join(d, f"s{nt}_{c}.npz"))
                    t0 = time.process_time()
                    loop = build_loop(cfg, a.law, a.estimator, structure=structure_of(f))
                    row["build_cpu_s"] = round(time.process_time() - t0, 2)
                    steps = a.steps if row["points"] <= 24 else a.fine_steps
                    run(loop, EXC_FREQ_HZ, EXC_AMP_N, 0.01, timing=True)
                    A, B = [], []
                    for _ in range(a.reps):
                        A.append(medians(builtin, steps, (nt, c, "A")))
                        B.append(medians(loop, steps, (nt, c, "B")))
                    row["tails"], row["builtin_tails"] = tails((nt, c, "B")), tails((nt, c, "A"))
                    if a.paced_s > 0:
                        row["paced"], row["builtin_paced"] = [], []
                        for _ in range(a.paced_reps):
                            row["builtin_paced"].append(paced(builtin))
                            row["paced"].append(paced(loop))
                except (ValueError, RuntimeError) as e:
                    row["error"] = str(e)
                    print(f"{nt}-D friction, {row['points']:>3} points: {e}", flush=True)
                    out["rows"].append(row)
                    continue
                A, B = np.array(A), np.array(B)
                row.update(steps=steps, n_modes=int(loop.plant.n), tick_us=float(np.median(B[:, 0])),
                           plant_us=float(np.median(B[:, 1])), builtin_tick_us=float(np.median(A[:, 0])),
                           builtin_plant_us=float(np.median(A[:, 1])), tick_us_reps=B[:, 0].round(2).tolist(),
                           load_avg=os.getloadavg()[0])
                out["rows"].append(row)
                print(f"{nt}-D friction, {row['points']:>3} points ({row['n_modes']} coordinates): tick "
                      f"{row['tick_us']:8.2f}  plant {row['plant_us']:8.2f} | built-in tick {row['builtin_tick_us']:6.2f} "
                      f"plant {row['builtin_plant_us']:6.2f}  (reps {row['tick_us_reps']}, load {row['load_avg']:.1f})",
                      flush=True)
                t, tb = row["tails"], row["builtin_tails"]
                print(f"    pooled {t['ticks']} ticks: median / p99 / p99.9 / max {t['median_us']:.2f} / {t['p99_us']:.2f} / "
                      f"{t['p999_us']:.2f} / {t['max_us']:.1f} us | built-in {tb['median_us']:.2f} / {tb['p99_us']:.2f} / "
                      f"{tb['p999_us']:.2f} / {tb['max_us']:.1f} us", flush=True)
                for pa, pb in zip(row.get("paced", []), row.get("builtin_paced", [])):
                    print(f"    paced {a.paced_s:g} s: missed {pa['overruns']} of {pa['ticks'] + pa['overruns']} "
                          f"({100 * pa['overrun_rate']:.3f} %), late p99.9 {pa['late']['p999_us']:.1f} us, tick median "
                          f"{pa['tick_median_us']:.2f} / p99 {pa['tick_p99_us']:.1f} / p99.9 {pa['tick_p999_us']:.1f} / max "
                          f"{pa['tick_max_us']:.0f} us, {pa['ticks_over_period']} ticks over the period, {pa['wall_s']:.1f} s wall, "
                          f"passive {pa['passive_ticks']} ticks"
                          + (f" ({pa['fault']} from tick {pa['first_passive_tick']})" if pa['passive_ticks'] else "")
                          + f" | built-in missed {pb['overruns']} ({100 * pb['overrun_rate']:.3f} %), late p99.9 "
                          f"{pb['late']['p999_us']:.1f} us, tick median {pb['tick_median_us']:.2f} / p99 {pb['tick_p99_us']:.1f} / "
                          f"p99.9 {pb['tick_p999_us']:.1f} / max {pb['tick_max_us']:.0f} us, {pb['ticks_over_period']} over, "
                          f"passive {pb['passive_ticks']} ticks "
                          f"(load {os.getloadavg()[0]:.1f}; {pa['realtime']})", flush=True)
    ok = {}
    for r in out["rows"]:
        if "tick_us" in r and r["tick_us"] <= BUDGET_US:
            ok[r["friction_dims"]] = max(ok.get(r["friction_dims"], 0), r["points"])
    out["largest_within_budget"] = ok
    print(f"largest point count with the whole tick's median <= {BUDGET_US:g} us: {ok}")
    write_json(a.json, out)
    return 0


if __name__ == "__main__":
    run_main(main)
