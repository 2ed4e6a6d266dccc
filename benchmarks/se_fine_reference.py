"""The 3-D reference at the paper's interface size (plant.fe3d with 5 mm elements over the damper and
four across its width: 585 contact points; the paper's model had 632), and the coarsened
interfaces against it.

    python -m benchmarks.se_fine_reference [--cache REF.npz] [--interface-pitch 0.005] [--width-elems 4]
        [--clusters 6,8,16] [--clustering footprint[,footprint-patches]] [--hammer-groups 6,8,16]
        [--keep-gap-um 20] [--cost-steps 20]
        [--no-hammer] [--solver kernel|active-set] [--json OUT.json]

1. Build (or read --cache, written on the first run): the hexahedral model, its Craig-Bampton
   reduction (wall and CPU time), and the reduction check: every contact point stuck, the reduced
   model's lowest 8 frequencies against the full FE model's (sparse shift-invert Lanczos).
2. The plant of every point (build_se_plant, its build time): the closed-stuck vertical bending
   modes 2-5 at F_N1 = tracking.F_min_N (as benchmarks.se_footprint) and the step's cost on the
   full interface: the median wall time of --cost-steps plant steps of the hammer run (the kernel as
   the loop runs it, every point in the Newton).
3. The hammer test at F_N1 = 100 N (plant.se_analysis.impulse's pulse, record and fit) on the full
   interface, solved on its active set: the points open by more than --keep-gap-um in the static
   equilibrium are taken out of the contact solve (an open point carries no force: the normal
   penalty and the dashpots vanish for g_n > 0), and the run checks at every step that each of them
   stays open (g_n > 0 from the full model's rows); a point that closes stops the script. The
   adaptive bolt's reference separation is the full interface's. Wall time per simulated second.
   With --solver active-set, every point stays in the model and each substep's contact is solved on
   the points closed at its start or end (plant.se_offline): no point is taken out, nothing to check.
4. The interface coarsened by the bolts' footprints (plant.se_coarsen; --clustering footprint-patches:
   with the held patches' normal stiffness kept) to --clusters groups: the
   closed-stuck modes 2-5 at F_min against the full interface's, and the hammer test (--hammer-groups)
   against the full interface's hammer test.
Threads: run with OPENBLAS_NUM_THREADS=1 on a shared machine (docs/studies/superelement-3d.md 7).
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numba
import numpy as np

F_HAMMER_N = 100.0


def _watch_kernel():
    from frictionrt.plant.se_plant import _se_step
    from frictionrt.rt.common.clock import _now_ns

    @numba.njit(nogil=True)
    def run_watch(x0, U, p, wk, Y, G_out, step_ns, gmin):
        x = x0.copy()
        x_next = np.empty_like(x0)
        ts = np.zeros(2, dtype=np.int64)
        n = p.omega2.shape[0]
        failed = 0
        for k in range(U.shape[0]):
            t0 = _now_ns(ts)
            if _se_step(k, x, U[k], p, x_next, Y[k], wk) < 0:
                failed += 1
            step_ns[k] = _now_ns(ts) - t0
            x, x_next = x_next, x
            lo = np.inf
            for i in range(G_out.shape[0]):
                acc = 0.0
                for j in range(n):
                    acc += G_out[i, j] * x[j]
                lo = min(lo, acc)
            gmin[k] = lo
        return x, failed
    return run_watch


def build_reference(cfg, a, out):
    """The reference superelement, built (and cached) or read; and its plant."""
    from frictionrt.plant import fe3d
    from frictionrt.plant import superelement as S
    from frictionrt.plant.se_plant import build_se_plant, stuck_frequencies_hz
    info = None
    if a.cache and os.path.exists(a.cache):
        se = S.load(a.cache)
        out["build"] = b = {"cached": a.cache}
        print(f"3-D reference read from {a.cache}: {se.n} coordinates, {se.n_points} contact points", flush=True)
    else:
        t0, c0 = time.perf_counter(), time.process_time()
        se, info = fe3d.reference_superelement(cfg, interface_pitch_m=a.interface_pitch, pitch_m=a.pitch,
                                               width_elems=a.width_elems, cutoff_hz=a.cutoff)
        out["build"] = b = {"n_full": info["n_full"], "n_reduced": info["n_reduced"], "n_boundary": info["n_boundary"],
                            "n_points": info["n_points"], "wall_s": round(time.perf_counter() - t0, 1),
                            "cpu_s": round(time.process_time() - c0, 1), "load_avg": os.getloadavg()[0]}
        print(f"3-D reference: {b['n_full']} DOFs, {b['n_points']} contact points, reduced to {b['n_reduced']} "
              f"({b['n_boundary']} boundary DOFs); {b['wall_s']} s wall, {b['cpu_s']} s CPU (load {b['load_avg']:.1f})",
              flush=True)
        if a.cache:
            S.save(se, a.cache)
    t0, c0 = time.perf_counter(), time.process_time()
    plant = build_se_plant(se, cfg)
    b.update(plant_build_wall_s=round(time.perf_counter() - t0, 1), plant_build_cpu_s=round(time.process_time() - c0, 1),
             plant_coordinates=plant.n)
    print(f"plant of every point: {plant.n} coordinates stepped, built in {b['plant_build_wall_s']} s wall "
          f"({b['plant_build_cpu_s']} s CPU)", flush=True)
    if info is not None:
        itf = cfg.plant.interface
        t0 = time.perf_counter()
        f_full = fe3d.full_stuck_frequencies_hz(info, None, itf.k_n_area * se.contact_area,
                                                itf.k_t_area * se.contact_area)
        b["full_check_s"] = round(time.perf_counter() - t0, 1)
        f_red = stuck_frequencies_hz(plant, closed_only=False)[:8]
        b["full_stuck_hz"] = f_full.round(3).tolist()
        b["reduced_stuck_hz"] = f_red.round(3).tolist()
        b["reduction_error_pct"] = (100 * (f_red / f_full - 1)).round(4).tolist()
        print("every point stuck: full FE [Hz] | reduced [Hz] | error [%]")
        for i, (ff, fr) in enumerate(zip(f_full, f_red)):
            print(f"  mode {i + 1}: {ff:10.3f} {fr:10.3f} {100 * (fr / ff - 1):+9.4f}", flush=True)
    return se, plant


def active_set_plant(se, plant, cfg, g_n: np.ndarray, keep_gap_m: float):
    """The plant of se's points whose normal gap g_n [m] (the static equilibrium's, one per point) is below
    keep_gap_m [m] (the others taken out of the contact solve), with the adaptive bolt's reference
    separation of the full interface's plant; and the normal-gap rows of the points taken out, in
    the new plant's coordinates (for the run's check that they stay open)."""
    from dataclasses import replace
    from frictionrt.plant.se_plant import build_se_plant
    keep = g_n < keep_gap_m
    sub = se.with_(contact_rows=np.ascontiguousarray(se.contact_rows[keep]), contact_area=se.contact_area[keep],
                   contact_xyz=None if se.contact_xyz is None else se.contact_xyz[keep],
                   contact_normal=None if se.contact_normal is None else se.contact_normal[keep],
                   contact_gap0=None if se.contact_gap0 is None else se.contact_gap0[keep],
                   source=f"{se.source}, {int(keep.sum())} of {se.n_points} points (open by >= {keep_gap_m:g} m out)")
    ps = build_se_plant(sub, cfg)
    p = ps.params
    ref = plant.params.bolt_ref
    p = p._replace(bolt_ref=ref, f_const=p.f_const + p.bolt_row * p.bolt_k * (ref - p.bolt_ref))
    ps = replace(ps, params=p)
    G_out = np.ascontiguousarray(se.contact_rows[~keep, 0, :] @ ps.Phi)
    gap0_out = np.zeros(int((~keep).sum())) if se.contact_gap0 is None else se.contact_gap0[~keep]
    if np.any(gap0_out):
        raise ValueError("the active-set check assumes no initial gaps (contact_gap0) at the points taken out")
    return ps, G_out, keep


def vertical_modes(plant, F_N1):
    """(vertical bending modes 2-5 [Hz] stuck at the points closed at F_N1 [N], as
    benchmarks.superelement_reference's, and the number of closed points): one static solve."""
    from frictionrt.plant.se_analysis import _stuck_modes
    f, V, closed = _stuck_modes(plant, F_N1)
    names = plant.se.sensor_names
    z = np.abs(plant.params.S[names.index("tip")] @ V)
    y = np.abs(plant.params.S[names.index("tip_y")] @ V)
    return f[(z > y) & (f > 1.0)][1:5], int(closed.sum())


def hammer_row(plant, cfg, sensor, ref_hammer: dict) -> dict:
    """The 100 N hammer test on ``plant`` (``impulse``): its f [Hz] and zeta, their error against
    ``ref_hammer`` (f in %, zeta as a ratio) and its wall time [s]."""
    from frictionrt.plant.se_analysis import impulse
    t0 = time.perf_counter()
    h = impulse(plant, cfg, F_HAMMER_N, sensor=sensor)
    return {"hammer_f_hz": h["freq_hz"], "hammer_zeta": h["damping_ratio"],
            "hammer_s": round(time.perf_counter() - t0, 1),
            "hammer_f_err_pct": (100 * (np.array(h["freq_hz"]) / ref_hammer["freq_hz"] - 1)).round(2).tolist(),
            "hammer_zeta_ratio": (np.array(h["damping_ratio"]) / ref_hammer["damping_ratio"]).round(3).tolist()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", default=None, help="the reduced reference as .npz (written if missing)")
    ap.add_argument("--interface-pitch", type=float, default=0.005)
    ap.add_argument("--pitch", type=float, default=0.02)
    ap.add_argument("--width-elems", type=int, default=4)
    ap.add_argument("--cutoff", type=float, default=4000.0)
    ap.add_argument("--clusters", default="6,8,16", help="footprint groups of the coarsened interfaces")
    ap.add_argument("--hammer-groups", default="6,8,16", help="the coarsened interfaces' hammer tests")
    ap.add_argument("--clustering", default="footprint", help="the coarsened interfaces' groupings, comma-separated "
                    "(plant.superelement.CLUSTERINGS but coordinates: footprint, footprint-patches)")
    ap.add_argument("--keep-gap-um", type=float, default=20.0, help="the hammer's active set: points open by less")
    ap.add_argument("--cost-steps", type=int, default=20, help="plant steps timed on the full interface")
    ap.add_argument("--record-s", type=float, default=None, help="the hammer record (default impulse.record_s)")
    ap.add_argument("--no-hammer", action="store_true")
    ap.add_argument("--solver", choices=("kernel", "active-set"), default="kernel",
                    help="the hammer's contact solve: the plant kernel on the points open by less than --keep-gap-um, "
                         "or plant.se_offline's active-set solve on every point")
    ap.add_argument("--chunk", type=int, default=525, help="the hammer run's steps between progress lines")
    ap.add_argument("--hammer-budget-s", type=float, default=1e9,
                    help="end the hammer record after this wall time [s]; the fits then use the record as run")
    ap.add_argument("--coarse-reference", action="store_true",
                    help="also the 57-point reference and its footprint groups against the fine interface")
    ap.add_argument("--build-only", action="store_true")
    ap.add_argument("--json", metavar="OUT.json")
    a = ap.parse_args(argv)
    from frictionrt.plant.superelement import CLUSTERINGS
    bad = [c for c in a.clustering.split(",") if c not in CLUSTERINGS]
    if bad:
        ap.error(f"--clustering {bad[0]!r}: give one or more of {', '.join(CLUSTERINGS)}, comma-separated")
    from benchmarks.se_patch_stiffness import footprint_closed_of
    from frictionrt import jobs
    from frictionrt.plant.impulse import hammer_force
    from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
    from frictionrt.plant.se_analysis import _timed_run, fit_hammer
    from frictionrt.plant.se_coarsen import classes_of, coarsen_structure, footprint_levels_n
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.rt.common.config import Config, with_sets
    cfg = Config()
    if a.record_s:
        cfg = with_sets(cfg, [f"impulse.record_s={a.record_s}"])
    out: dict = {"load_avg_start": os.getloadavg()[0]}

    def dump():
        if a.json:
            with open(a.json, "w") as fh:
                json.dump(out, fh, indent=1)
    se, plant = build_reference(cfg, a, out)
    dump()
    if a.build_only:
        return 0
    F_min = cfg.tracking.F_min_N
    sensor = cfg.plant.frf_point if cfg.plant.frf_point in se.sensor_names else se.sensor_names[0]

    # --- 2. closed-stuck modes, the 2-D beams beside them, the full interface's step cost
    f_st, n_cl = vertical_modes(plant, F_min)
    ref = {"points": se.n_points, "closed_F_min": n_cl, "closed_hammer": None, "stuck_hz": f_st.round(3).tolist()}
    d = 1 + plant.params.nt
    x_hammer = plant.initial_state(F_HAMMER_N)
    g_n = x_hammer[plant.state_slots()["g"]][0::d]
    ref["closed_hammer"] = int((g_n < 0).sum())
    ref["open_by_um_at_hammer"] = {str(t): int((g_n > 1e-6 * t).sum()) for t in (0, 1, 2, 5, 10, 20, 50, 100)}
    print(f"points open at {F_HAMMER_N:g} N by more than t um: {ref['open_by_um_at_hammer']}", flush=True)
    m2 = build_plant(cfg)
    ref["stuck_2d_hz"] = stuck_frequencies_hz(m2, preloaded_pairs(m2, F_min))[1:5].round(3).tolist()
    out["reference"] = ref
    print(f"{se.n_points} points: closed {ref['closed_F_min']} at {F_min:g} N, {ref['closed_hammer']} at "
          f"{F_HAMMER_N:g} N; closed-stuck modes 2-5 at {F_min:g} N {ref['stuck_hz']} Hz (2-D beams {ref['stuck_2d_hz']})",
          flush=True)
    imp = cfg.impulse
    n_rec = int(round(imp.record_s / cfg.dt_s))
    force = hammer_force(n_rec, cfg.dt_s, imp.peak_N, imp.duration_s)
    if a.cost_steps:
        k = a.cost_steps
        U = np.column_stack([force[:k], np.full(k, F_HAMMER_N)])
        Y = np.zeros((k, len(plant.output_labels())))
        ns = np.zeros(k, dtype=np.int64)
        t0 = time.perf_counter()
        _, failed = _timed_run(x_hammer, U, plant.params, plant.new_work(), Y, ns)
        ix = plant.output_index()
        ref["full_cost"] = {"steps": k, "wall_s": round(time.perf_counter() - t0, 1), "failed": int(failed),
                            "median_ms": float(np.median(ns) / 1e6), "max_ms": float(ns.max() / 1e6),
                            "newton_iter_mean": float(Y[:, ix["newton_iter"]].mean()),
                            "refactorisations_mean": float(Y[:, ix["refactorisations"]].mean()),
                            "load_avg": os.getloadavg()[0]}
        print(f"step on all {se.n_points} points ({plant.params.G.shape[0]} gaps, {plant.n} coordinates): median "
              f"{ref['full_cost']['median_ms']:.1f} ms, max {ref['full_cost']['max_ms']:.1f} ms over {k} steps of the "
              f"hammer run; Newton {ref['full_cost']['newton_iter_mean']:.2f}, refactorisations "
              f"{ref['full_cost']['refactorisations_mean']:.2f} a step (load {os.getloadavg()[0]:.1f})", flush=True)
    dump()

    # --- 3. the hammer test at F_N1 = 100 N on the active set, checked
    if not a.no_hammer:
        t0 = time.perf_counter()
        if a.solver == "active-set":   # every point in the model, the contact solved on its active set
            from frictionrt.plant.se_offline import ActiveSetStepper
            ps, keep, G_out = plant, np.ones(se.n_points, bool), np.zeros((0, plant.n))
        else:
            ps, G_out, keep = active_set_plant(se, plant, cfg, g_n, 1e-6 * a.keep_gap_um)
        build_s = time.perf_counter() - t0
        x = x_hammer.copy() if ps is plant else ps.initial_state(F_HAMMER_N)
        sens = plant.params.S @ x_hammer[:plant.n]
        sens_sub = ps.params.S @ x[:ps.n]
        U = np.column_stack([force, np.full(n_rec, F_HAMMER_N)])
        Y = np.zeros((n_rec, len(ps.output_labels())))
        ns = np.zeros(n_rec, dtype=np.int64)
        gmin = np.full(n_rec, np.inf)
        if a.solver == "active-set":
            stepper = ActiveSetStepper(ps)

            def kern(x, U, p, wk, Y, G_out, ns, gmin):
                x = x.copy()
                failed = 0
                for k in range(U.shape[0]):
                    t = time.perf_counter_ns()
                    failed += stepper.step(x, U[k], Y[k]) < 0
                    ns[k] = time.perf_counter_ns() - t
                return x, failed
        else:
            kern = _watch_kernel()
        wk = ps.new_work()
        done, stop = 0, "the record"
        t0, c0 = time.perf_counter(), time.process_time()
        while done < n_rec:   # in chunks: a wall-time budget and a closing point end the record early
            e = min(done + a.chunk, n_rec)
            x, failed = kern(x, U[done:e], ps.params, wk, Y[done:e], G_out, ns[done:e], gmin[done:e])
            if failed:
                stop = f"a failed contact solve in steps {done}..{e}"
                break
            if (~keep).any() and gmin[done:e].min() <= 0.0:
                done += int(np.argmax(gmin[done:e] <= 0.0))   # the steps before the one where a point closed
                stop = "a point taken out of the solve closed"
                break
            done = e
            el = time.perf_counter() - t0
            print(f"  hammer: {done * cfg.dt_s:.3f} s of {imp.record_s:g} s simulated, {el:.0f} s wall, step median "
                  f"{np.median(ns[:done]) / 1e3:.0f} us, smallest gap out {1e6 * gmin[:done].min():.3f} um "
                  f"(load {os.getloadavg()[0]:.1f})", flush=True)
            if el > a.hammer_budget_s:
                stop = f"the wall-time budget ({a.hammer_budget_s:g} s)"
                break
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        if done < 2 * a.chunk:
            raise RuntimeError(f"the hammer run ended after {done} steps: {stop}")
        if done < n_rec:   # the record as run: every comparison below uses the same length and window
            n_rec = done
            cfg = with_sets(cfg, [f"impulse.record_s={n_rec * cfg.dt_s!r}"])
            imp = cfg.impulse
            force = force[:n_rec]
        ns, Y, gmin = ns[:n_rec], Y[:n_rec], gmin[:n_rec]
        h = fit_hammer(ps, cfg, F_HAMMER_N, force, Y, sensor)
        h2 = jobs.impulse(cfg, fn1_n=F_HAMMER_N).to_dict()
        two = {int(m): (f, z) for m, f, z in zip(h2["modes"], h2["freq_hz"], h2["damping_ratio"])}
        ix = ps.output_index()
        hr = {"points_in_solve": int(keep.sum()),
              "smallest_gap_out_static_um": float(1e6 * g_n[~keep].min()) if (~keep).any() else None,
              "smallest_gap_out_run_um": float(1e6 * gmin.min()) if (~keep).any() else None, "static_sensor_max_diff_m":
              float(np.abs(sens - sens_sub).max()), "static_sensor_scale_m": float(np.abs(sens).max()),
              "build_s": round(build_s, 1), "coordinates": ps.n, "wall_s": round(wall, 1), "cpu_s": round(cpu, 1),
              "record_s": imp.record_s, "ended_by": stop, "wall_per_sim_s": round(wall / imp.record_s, 1), "tick_median_us": float(np.median(ns) / 1e3),
              "tick_p99_us": float(np.percentile(ns, 99) / 1e3),
              "newton_iter_mean": float(Y[:, ix["newton_iter"]].mean()),
              "refactorisations_mean": float(Y[:, ix["refactorisations"]].mean()),
              "load_avg": os.getloadavg()[0], **h,
              "two_d": [two[m] for m in (2, 3, 4, 5)]}
        ref["hammer"] = hr
        print(f"hammer at F_N1 = {F_HAMMER_N:g} N on {hr['points_in_solve']} of {se.n_points} points "
              f"({ps.n} coordinates; the others open by >= {hr['smallest_gap_out_static_um']} um at rest, "
              f">= {hr['smallest_gap_out_run_um']} um over the run; static sensors agree to "
              f"{hr['static_sensor_max_diff_m']:.2e} m of {hr['static_sensor_scale_m']:.2e}): f {h['freq_hz']} Hz, "
              f"zeta {h['damping_ratio']}; {wall:.0f} s wall ({cpu:.0f} s CPU) for {imp.record_s:g} s, tick median "
              f"{hr['tick_median_us']:.0f} us, p99 {hr['tick_p99_us']:.0f} us, Newton {hr['newton_iter_mean']:.2f}, "
              f"refactorisations {hr['refactorisations_mean']:.3f} a step (load {hr['load_avg']:.1f})", flush=True)
        if hr["smallest_gap_out_run_um"] is not None and hr["smallest_gap_out_run_um"] <= 0.0:
            raise RuntimeError("a point taken out of the solve closed during the run: raise --keep-gap-um")
        print(f"2-D beams: {two}")
        dump()

    # --- 4. the coarsened interfaces against the full one
    def add_row(key: str, rows: list, r: dict, label: str, fill) -> None:
        """fill(r) adds a coarse interface's figures to r and returns its line; an interface that
        does not build (no equilibrium, a count out of range) is a row with its one-line error."""
        try:
            print(f"{label}: {fill(r)}", flush=True)
        except (RuntimeError, ValueError) as e:
            r["error"] = str(e)
            print(f"{label}: {e}", flush=True)
        rows.append(r)
        out[key] = rows
        dump()

    def stuck_and_hammer(pc, r: dict, hammer: bool) -> str:
        f_st, r["closed_F_min"] = vertical_modes(pc, F_min)
        r["stuck_hz"] = f_st.round(3).tolist()
        r["stuck_err_pct"] = (100 * (np.array(r["stuck_hz"]) / ref["stuck_hz"] - 1)).round(2).tolist()
        line = f"closed {r['closed_F_min']} at {F_min:g} N, stuck modes 2-5 {r['stuck_err_pct']} %"
        if hammer:
            r.update(hammer_row(pc, cfg, sensor, ref["hammer"]))
            line += f"; hammer f {r['hammer_f_err_pct']} %, zeta ratio {r['hammer_zeta_ratio']} ({r['hammer_s']} s)"
        return line

    rows = []
    hg = {int(c) for c in a.hammer_groups.split(",") if c}
    closed = None
    for c in (int(x) for x in a.clusters.split(",") if x):
        for cl in a.clustering.split(","):
            def fill(r, c=c, cl=cl):
                nonlocal closed
                t0 = time.perf_counter()
                if closed is None:
                    closed = footprint_closed_of(plant, cfg)
                    out["footprint_classes"] = np.bincount(classes_of(closed)).tolist()
                    print(f"footprint classes of the {se.n_points} points (closed at {footprint_levels_n(cfg)} N, open): "
                          f"{out['footprint_classes']} ({time.perf_counter() - t0:.0f} s)", flush=True)
                pc = build_se_plant(coarsen_structure(se, c, cfg, cl, closed=closed), cfg)
                r["build_s"] = round(time.perf_counter() - t0, 1)
                return stuck_and_hammer(pc, r, c in hg and "hammer" in ref)
            add_row("coarse", rows, {"groups": c, "clustering": cl}, f"{c:>3} groups, {cl}", fill)
    # --- 5. the 57-point reference (benchmarks.se_footprint's) and its coarsened interfaces against the fine one
    if a.coarse_reference and "hammer" in ref:
        from frictionrt.plant import fe3d
        se57, _ = fe3d.reference_superelement(cfg)
        rows57 = []
        for c in [0] + [int(x) for x in a.clusters.split(",") if x]:
            add_row("coarse_57", rows57, {"points": se57.n_points, "groups": c}, f"57 points, {c or 'all':>3} groups",
                    lambda r, c=c: stuck_and_hammer(build_se_plant(coarsen_structure(se57, c, cfg, "footprint"), cfg),
                                                    r, True))
    out["load_avg_end"] = os.getloadavg()[0]
    dump()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
