"""The offline active-set solve (plant.se_offline) against the plant kernel (plant.se_plant._se_step)
on the first steps of the hammer test: the same trajectory to the Newton tolerance, and the cost
of each in the same run (A/B, alternating).

    python -m benchmarks.se_offline_ab [--cache REF.npz] [--steps 20] [--reps 2] [--F-N1 100]
        [--keep-gap-um U] [--kernel-parts] [--profile] [--json OUT.json]

Without --cache the small 3-D reference of tests/test_se_plant (plant.fe3d, 40 mm over the damper).
--keep-gap-um: also the plant of the points open by less than U um at rest (as
benchmarks.se_fine_reference's hammer), both solvers on it.
Threads: run with OPENBLAS_NUM_THREADS=1 on a shared machine.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np
from benchmarks.entry import run_main, write_json

COARSE = {"interface_pitch_m": 0.04, "pitch_m": 0.05, "cutoff_hz": 4000.0}


def hammer_inputs(cfg, steps: int, F_N1: float) -> np.ndarray:
    from frictionrt.plant.impulse import hammer_force
    imp = cfg.impulse
    n_rec = int(round(imp.record_s / cfg.dt_s))
    force = hammer_force(n_rec, cfg.dt_s, imp.peak_N, imp.duration_s)[:steps]
    return np.column_stack([force, np.full(len(force), F_N1)])


def kernel_run(plant, U, x0):
    """The plant kernel step by step; (Y, states (steps + 1, size), wall per step [s])."""
    from frictionrt.plant.se_plant import _se_step
    p, wk = plant.params, plant.new_work()
    X = np.zeros((len(U) + 1, len(x0)))
    X[0] = x0
    Y = np.zeros((len(U), len(plant.output_labels())))
    ns = np.zeros(len(U))
    for k in range(len(U)):
        t0 = time.perf_counter()
        _se_step(k, X[k], U[k], p, X[k + 1], Y[k], wk)
        ns[k] = time.perf_counter() - t0
    return Y, X, ns


def active_run(plant, U, x0):
    from frictionrt.plant.se_offline import ActiveSetStepper
    st = ActiveSetStepper(plant)
    X = np.zeros((len(U) + 1, len(x0)))
    X[0] = x0
    Y = np.zeros((len(U), len(plant.output_labels())))
    ns = np.zeros(len(U))
    for k in range(len(U)):
        X[k + 1] = X[k]
        t0 = time.perf_counter()
        st.step(X[k + 1], U[k], Y[k])
        ns[k] = time.perf_counter() - t0
    return Y, X, ns


def kernel_parts(plant, x0, U, reps: int = 3) -> dict:
    """Wall time [s] of the kernel's parts on this plant, each called alone (median of reps), after
    one kernel step from x0 (so the work arrays hold a step's state): the Jacobian's build and LU
    (_factor_jacobian), one residual (_residual), one evaluation of the law (_mean_forces), and the
    predictor's and update's products G q, G^T Lambda (numpy, as a stand-in for the kernel's loops
    of the same size)."""
    from frictionrt.plant.se_plant import _factor_jacobian, _mean_forces, _residual, _se_step
    p, wk = plant.params, plant.new_work()
    x1 = np.empty_like(x0)
    y = np.zeros(len(plant.output_labels()))
    _se_step(0, x0, U[0], p, x1, y, wk)
    sl = plant.state_slots()
    g, w = x1[sl["g"]].copy(), x1[sl["w"]].copy()

    def best(fn):
        ts = []
        for _ in range(reps):
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
        return float(np.median(ts))
    q = x1[:plant.n].copy()
    return {"factor_jacobian_s": best(lambda: _factor_jacobian(p, wk)),
            "residual_s": best(lambda: _residual(p, wk)),
            "mean_forces_s": best(lambda: _mean_forces(g, wk.g1, w, p, wk, True)),
            "G_q_s": best(lambda: p.G @ q), "GT_lam_s": best(lambda: p.G.T @ wk.lam)}


def compare(plant, Xa, Xb) -> dict:
    """Largest differences of the two runs' gaps [m] and sensor displacements [m] over the steps,
    against their scales."""
    sl = plant.state_slots()
    n = plant.n
    dg = np.abs(Xa[:, sl["g"]] - Xb[:, sl["g"]]).max()
    s_a, s_b = Xa[:, :n] @ plant.params.S.T, Xb[:, :n] @ plant.params.S.T
    return {"gap_max_diff_m": float(dg), "gap_scale_m": float(np.abs(Xa[:, sl["g"]]).max()),
            "sensor_max_diff_m": float(np.abs(s_a - s_b).max()), "sensor_scale_m": float(np.abs(s_a).max()),
            "sensor_motion_m": float(np.abs(s_a - s_a[0]).max())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", default=None)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--F-N1", type=float, default=100.0)
    ap.add_argument("--keep-gap-um", type=float, default=None)
    ap.add_argument("--kernel-parts", action="store_true", help="time the kernel's parts alone")
    ap.add_argument("--profile", action="store_true", help="cProfile of one active-set run")
    ap.add_argument("--json", metavar="OUT.json")
    a = ap.parse_args(argv)
    from frictionrt.plant import superelement as S
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.rt.common.config import Config
    cfg = Config()
    if a.cache:
        se = S.load(a.cache)
    else:
        from frictionrt.plant import fe3d
        se, _ = fe3d.reference_superelement(cfg, **COARSE)
    t0 = time.process_time()
    plant = build_se_plant(se, cfg)
    out = {"points": se.n_points, "coordinates": plant.n, "gaps": plant.params.G.shape[0],
           "plant_build_cpu_s": round(time.process_time() - t0, 1), "steps": a.steps}
    x0 = plant.initial_state(a.F_N1)
    if a.keep_gap_um is not None:
        from benchmarks.se_fine_reference import active_set_plant
        g_n = x0[plant.state_slots()["g"]][0::1 + plant.params.nt]
        plant, _, keep = active_set_plant(se, plant, cfg, g_n, 1e-6 * a.keep_gap_um)
        x0 = plant.initial_state(a.F_N1)
        out.update(points_in_solve=int(keep.sum()), gaps=plant.params.G.shape[0])
    print(f"{se.n_points} points, {out['gaps']} gaps, {plant.n} coordinates; plant built in "
          f"{out['plant_build_cpu_s']} s CPU", flush=True)
    U = hammer_inputs(cfg, a.steps, a.F_N1)
    closed = int((x0[plant.state_slots()["g"]][0::1 + plant.params.nt] < 0).sum())
    out["closed_at_rest"] = closed
    ix = plant.output_index()
    if a.kernel_parts:
        out["kernel_parts"] = kp = kernel_parts(plant, x0, U)
        print("kernel's parts, one call each [ms]: " + ", ".join(f"{k[:-2]} {1e3 * v:.2f}" for k, v in kp.items()),
              flush=True)
    rows = []
    for rep in range(a.reps):
        for name, fn in (("kernel", kernel_run), ("active_set", active_run)):
            Y, X, ns = fn(plant, U, x0)
            rows.append({"rep": rep, "solver": name, "median_s": float(np.median(ns)), "total_s": float(ns.sum()),
                         "newton_iter_mean": float(Y[:, ix["newton_iter"]].mean()),
                         "refactorisations_mean": float(Y[:, ix["refactorisations"]].mean()),
                         "failed": int(Y[:, ix["substep_fallbacks"]].sum()), "load_avg": os.getloadavg()[0]})
            print(f"  rep {rep} {name:>10}: median {1e3 * rows[-1]['median_s']:9.2f} ms a step, "
                  f"{rows[-1]['total_s']:7.2f} s for {a.steps} steps, Newton {rows[-1]['newton_iter_mean']:.2f}, "
                  f"refactorisations {rows[-1]['refactorisations_mean']:.2f} a step, failed "
                  f"{rows[-1]['failed']} (load {rows[-1]['load_avg']:.1f})", flush=True)
            if rep == 0:
                if name == "kernel":
                    Xk = X
                else:
                    out["agreement"] = compare(plant, Xk, X)
                    print(f"  agreement: {out['agreement']}", flush=True)
    out["runs"] = rows
    med = {s: np.median([r["median_s"] for r in rows if r["solver"] == s]) for s in ("kernel", "active_set")}
    out["speedup_median"] = float(med["kernel"] / med["active_set"])
    print(f"speed-up of the step's median: {out['speedup_median']:.1f}x", flush=True)
    if a.profile:
        import cProfile
        import pstats
        pr = cProfile.Profile()
        pr.enable()
        active_run(plant, U, x0)
        pr.disable()
        pstats.Stats(pr).sort_stats("tottime").print_stats(12)
    write_json(a.json, out)
    return 0


if __name__ == "__main__":
    run_main(main)
