"""Step-sine peaks of the plant alone at constant F_N1 on the 585-point 3-D reference (every point,
plant.se_offline's active-set solve) and on the built-in 2-D beams, the same procedure on both.

    python -m benchmarks.se_fine_stepsine --cache REF.npz [--modes 4,5] [--amps 5,20] [--lines 5]
        [--span 0.03] [--spans 4:0.04,5:0.02] [--centres 4:372,5:615] [--F-N1 40] [--settle-tol 0.02] [--max-s 0.3]
        [--coarse 6:footprint-patches,...] [--no-fine] [--no-3d] [--json OUT.json]

Per mode and force amplitude A: --lines frequencies spread over +-span (relative) around the 2-D
beams' closed-stuck frequency at F_N1 (or --centre-3d: the 3-D reference's), stepped upwards with the
state carried from line to line (a stepped sine). At each line the force A sin(2 pi f t) along the
excitation, in blocks of at least 10 periods and 20 ms; per block the accelerance H at the FRF point
(a least-squares fit of cos, sin and a constant over the block's accelerations, divided by A); the
line is settled when |H| changes by less than --settle-tol between two blocks, or is measured after
--max-s. The peak is the line of the largest |H|, refined by a parabola through it and its
neighbours in (f, |H|): its frequency's resolution is the line spacing (span 2 / (lines - 1)).
--coarse GROUPS:CLUSTERING,...: the same procedure on the 585 points' interface coarsened
(plant.se_coarsen.coarsen_structure, the footprints solved once on the fine plant), stepped by the
loop's kernel (plant.se_plant); --no-fine skips the 585 points' own runs (hours; their peaks are in
docs/studies/superelement-offline.md) but still builds their plant for the footprints.
This is the plant alone (F_N1 held exactly), not the closed loop's ``compare --mode`` of
benchmarks.se_2d_vs_3d, so its peaks are compared with the 2-D beams' from this same script.
Threads: OPENBLAS_NUM_THREADS=1 on a shared machine.
"""
from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np
from benchmarks.entry import run_main, write_json


def block_ticks(f: float, dt: float) -> int:
    periods = max(10, math.ceil(0.02 * f))
    return int(round(periods / f / dt))


def fit_H(acc: np.ndarray, f: float, t: np.ndarray, amp: float) -> complex:
    """Accelerance at f [Hz] of acc over times t for the force amp sin(2 pi f t): least squares of
    acc = a cos + b sin + c; with the force's phase as reference H = (b + i a) / amp."""
    w = 2 * np.pi * f
    A = np.column_stack([np.cos(w * t), np.sin(w * t), np.ones_like(t)])
    (a, b, _), *_ = np.linalg.lstsq(A, acc, rcond=None)
    return complex(b, a) / amp


def stepped_sine(run_block, x, freqs, amp, dt, tol, max_s):
    """run_block(x, U) -> (x, acc (len(U),)); returns (rows, x): per line f, |H|, blocks, settled."""
    rows = []
    for f in freqs:
        nb = block_ticks(f, dt)
        k0 = 0
        H_prev = None
        settled = False
        n_blocks = 0
        while k0 * dt < max_s:
            t = (k0 + np.arange(nb)) * dt
            U = np.column_stack([amp * np.sin(2 * np.pi * f * t), np.zeros(nb)])
            x, acc = run_block(x, U)
            H = fit_H(acc, f, t, amp)
            n_blocks += 1
            k0 += nb
            if H_prev is not None and abs(abs(H) - abs(H_prev)) < tol * abs(H):
                settled = True
                break
            H_prev = H
        rows.append({"f_hz": float(f), "H_abs": abs(H), "blocks": n_blocks, "settled": settled,
                     "sim_s": round(k0 * dt, 4)})
    return rows, x


def peak_of(rows):
    f = np.array([r["f_hz"] for r in rows])
    H = np.array([r["H_abs"] for r in rows])
    k = int(np.argmax(H))
    if 0 < k < len(f) - 1:   # parabola through the largest line and its neighbours
        c = np.polyfit(f[k - 1:k + 2], H[k - 1:k + 2], 2)
        if c[0] < 0:
            fp = -c[1] / (2 * c[0])
            return float(fp), float(np.polyval(c, fp)), k
    return float(f[k]), float(H[k]), k


def coarse_runner(plant, F_N1: float, sensor: str):
    """run_block for a coarsened interface: the loop's kernel (plant.se_plant.run) with F_N1 held."""
    from frictionrt.plant.se_plant import run
    ix = plant.output_index()[f"a_{sensor}"]

    def run_block(x, U):
        Y, x = run(plant, U[:, 0], F_N1, x0=x)
        return x, Y[:, ix]
    return run_block


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", required=True)
    ap.add_argument("--modes", default="4,5")
    ap.add_argument("--amps", default="5,20")
    ap.add_argument("--lines", type=int, default=5)
    ap.add_argument("--span", type=float, default=0.03, help="relative half-width of the lines around the centre")
    ap.add_argument("--spans", default=None, metavar="MODE:REL,...", help="--span per mode")
    ap.add_argument("--F-N1", type=float, default=None, help="constant bolt force [N] (default tracking.F_passive_N)")
    ap.add_argument("--settle-tol", type=float, default=0.02)
    ap.add_argument("--max-s", type=float, default=0.3, help="longest run of one line [s]")
    ap.add_argument("--centre-3d", action="store_true")
    ap.add_argument("--centres", default=None, metavar="MODE:HZ,...",
                    help="the lines' centres per mode [Hz] (e.g. a previous run's peaks), instead of the stuck frequencies")
    ap.add_argument("--no-3d", action="store_true")
    ap.add_argument("--coarse", default="", metavar="GROUPS:CLUSTERING,...",
                    help="also these coarsened interfaces of the 585 points (e.g. 6:footprint,6:footprint-patches)")
    ap.add_argument("--no-fine", action="store_true", help="skip the 585 points' own runs (not their plant)")
    ap.add_argument("--json", metavar="OUT.json")
    a = ap.parse_args(argv)
    from frictionrt.plant import superelement as S
    coarse = []
    for spec in (c for c in a.coarse.split(",") if c):
        groups, _, clustering = spec.partition(":")
        if not groups.isdigit() or int(groups) < 1 or clustering not in S.CLUSTERINGS:
            ap.error(f"--coarse {spec!r}: give GROUPS:CLUSTERING, GROUPS >= 1 and CLUSTERING one of "
                     f"{', '.join(S.CLUSTERINGS)} (e.g. 6:footprint-patches)")
        coarse.append((int(groups), clustering))
    from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
    from frictionrt.plant.se_offline import ActiveSetStepper
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.plant.simulate import _run as run2d
    from frictionrt.rt.common.config import Config
    from benchmarks.se_fine_reference import vertical_modes
    from benchmarks.se_patch_stiffness import footprint_closed_of
    from frictionrt.plant.se_coarsen import coarsen_structure
    cfg = Config()
    dt = cfg.dt_s
    F_N1 = cfg.tracking.F_passive_N if a.F_N1 is None else a.F_N1
    out = {"F_N1_N": F_N1, "lines": a.lines, "span": a.span, "settle_tol": a.settle_tol, "max_s": a.max_s,
           "load_avg_start": os.getloadavg()[0], "rows": []}
    m2 = build_plant(cfg)
    f2 = stuck_frequencies_hz(m2, preloaded_pairs(m2, F_N1))
    centres = {m: float(f2[m - 1]) for m in (2, 3, 4, 5)}
    ix2 = m2.output_index()[f"a_{cfg.plant.frf_point}"]

    def run_2d(x, U):
        U = U.copy()
        U[:, 1] = F_N1
        Y = np.zeros((len(U), len(m2.output_labels())))
        x, failed = run2d(x, U, m2.params, m2.new_work(), Y, np.zeros(len(U), dtype=np.int64))
        if failed:
            raise RuntimeError("the 2-D plant's contact solve failed")
        return x, Y[:, ix2]
    ps = None
    if not a.no_3d:
        t0 = time.process_time()
        se = S.load(a.cache)
        ps = build_se_plant(se, cfg)
        out["plant_build_cpu_s"] = round(time.process_time() - t0, 1)
        st = ActiveSetStepper(ps)
        sensor = cfg.plant.frf_point if cfg.plant.frf_point in se.sensor_names else se.sensor_names[0]
        ix3 = ps.output_index()[f"a_{sensor}"]
        Y1 = np.zeros(len(ps.output_labels()))
        x3_rest = ps.initial_state(F_N1)
        if a.centre_3d:
            f3, _ = vertical_modes(ps, F_N1)
            centres = {m: float(f3[m - 2]) for m in (2, 3, 4, 5)}

        def run_3d(x, U):
            acc = np.zeros(len(U))
            for k in range(len(U)):
                if st.step(x, (U[k, 0], F_N1), Y1) < 0:
                    raise RuntimeError("the 3-D active-set solve failed")
                acc[k] = Y1[ix3]
            return x, acc

        models = [] if a.no_fine else [("3-D 585", run_3d, lambda: x3_rest.copy())]
        closed = None
        for groups, clustering in coarse:
            if closed is None:
                closed = footprint_closed_of(ps, cfg)
            pc = build_se_plant(coarsen_structure(se, groups, cfg, clustering, closed=closed), cfg)
            models.append((f"{groups} {clustering}", coarse_runner(pc, F_N1, sensor), lambda pc=pc: pc.initial_state(F_N1)))
    if a.centres:
        centres.update({int(k): float(v) for k, v in (c.split(":") for c in a.centres.split(","))})
    print(f"F_N1 = {F_N1:g} N; line centres {centres} Hz", flush=True)
    for mode in (int(m) for m in a.modes.split(",")):
        span = dict((int(k), float(v)) for k, v in (c.split(":") for c in a.spans.split(","))).get(mode, a.span) \
            if a.spans else a.span
        freqs = centres[mode] * (1 + np.linspace(-span, span, a.lines))
        for amp in (float(v) for v in a.amps.split(",")):
            for name, fn, x0 in [("2-D", run_2d, lambda: m2.initial_state(F_N1))] + (models if ps is not None else []):
                t0, c0 = time.perf_counter(), time.process_time()
                rows, _ = stepped_sine(fn, x0(), freqs, amp, dt, a.settle_tol, a.max_s)
                fp, Hp, k = peak_of(rows)
                r = {"mode": mode, "amp_N": amp, "model": name, "peak_f_hz": round(fp, 3), "peak_H": round(Hp, 3),
                     "line_spacing_hz": round(float(freqs[1] - freqs[0]), 3), "peak_line": k,
                     "wall_s": round(time.perf_counter() - t0, 1), "cpu_s": round(time.process_time() - c0, 1),
                     "lines": rows, "load_avg": os.getloadavg()[0]}
                out["rows"].append(r)
                print(f"mode {mode}, {amp:g} N, {name}: peak {fp:.2f} Hz, |H| {Hp:.2f} (m/s^2)/N (line {k} of "
                      f"{len(rows)}, spacing {r['line_spacing_hz']} Hz; lines |H| "
                      f"{[round(x['H_abs'], 2) for x in rows]}, settled {[x['settled'] for x in rows]}; "
                      f"{r['wall_s']} s wall, load {r['load_avg']:.1f})", flush=True)
                write_json(a.json, out)
    return 0


if __name__ == "__main__":
    run_main(main)
