"""The harmonic-balance FRF (plant.harmonic_frf) against the nonlinear plant's step-sine: the table
of docs/plant.md section 10.

    python -m benchmarks.harmonic_frf [--cases lap_joint default lap_joint_iwan] [--json]

Per case (structure, passive F_N1 = tracking.F_passive_N held by the stack's voltage, the mode the
joint affects) and force level: the step-sine of the closed loop with the passive law
(rt.experiments.stepsine.sweep, up the lines, first harmonic of a_frf / F_exc), and the harmonic
balance on the same lines by method df (describing functions, normal contact linear), aft with
one harmonic and aft with three (plant.harmonic_frf). Reported: the peak (parabola through the
highest line and its neighbours) in frequency and magnitude, its errors against the step-sine,
the rms of 20 log10 |H_hb / H_ss| over the lines where the harmonic balance converged, the
largest normal-gap ratio (> 1: contact opens or closes, df's assumption broken), and the wall
time per line (the harmonic balance with its three starts per line and with one; one BLAS
thread for both, as the parallel step-sine runs).
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
from threadpoolctl import threadpool_limits

from frictionrt.plant.harmonic_frf import harmonic_accelerances, harmonic_system
from frictionrt.rt.common.config import load
from frictionrt.rt.experiments.stepsine import Settle, sweep
from frictionrt.rt.loop import build_loop
from benchmarks.entry import run_main

METHODS = (("df", 1), ("aft", 1), ("aft", 3))


def _lines(a: float, b: float, step: float) -> list[float]:
    return [round(a + step * i, 4) for i in range(int(round((b - a) / step)) + 1)]


# case: (config file, --set overrides, [(F_amp [N], lines [Hz], step-sine max_s [s])])
CASES = {
    "lap_joint": ("configs/lap_joint.toml", [], [
        (0.01, _lines(69.30, 69.60, 0.05), 20.0),     # stuck: every closed pair below its slip amplitude
        (0.3, _lines(69.40, 69.90, 0.05), 8.0),      # slip sets in at the outer pairs, the open end closes
        (2.0, _lines(69.20, 69.70, 0.05), 8.0)]),     # the outer pairs slide through most of the cycle
    "lap_joint_iwan": ("configs/lap_joint.toml", ["plant.interface.iwan_spread=0.5"], [
        (0.3, _lines(69.40, 69.90, 0.05), 8.0),
        (2.0, _lines(69.20, 69.70, 0.05), 8.0)]),
    "default": (None, [], [
        (0.2, _lines(220.0, 232.0, 1.0), 8.0),
        (1.0, _lines(205.0, 225.0, 2.0), 8.0),
        (5.0, _lines(196.0, 206.0, 1.0), 8.0)]),
}


def peak(f: np.ndarray, H: np.ndarray) -> tuple[float, float]:
    """(f_peak [Hz], |H|_peak): the vertex of the parabola through the highest |H| line and its
    neighbours (the line itself at an end of the grid or where |H| is NaN)."""
    a = np.abs(H)
    k = int(np.nanargmax(a))
    if 0 < k < len(f) - 1 and np.all(np.isfinite(a[k - 1:k + 2])):
        c = np.polyfit(f[k - 1:k + 2] - f[k], a[k - 1:k + 2], 2)
        if c[0] < 0:
            x = -c[1] / (2 * c[0])
            return float(f[k] + x), float(np.polyval(c, x))
    return float(f[k]), float(a[k])


def compare(config: str | None, sets: list[str], F_amp: float, lines: list[float], max_s: float) -> dict:
    """One level of one case (module docstring): rows per method and the step-sine."""
    cfg = load(config, sets=sets)
    F_N1 = cfg.tracking.F_passive_N
    loop = build_loop(cfg, "passive")
    t = time.perf_counter()
    with threadpool_limits(1):   # as rt.experiments.branches.run_branch: one BLAS thread for the fits
        ss = sweep(loop, lines, F_amp, settle=Settle(max_s=max_s))
    ss_s = (time.perf_counter() - t) / len(lines)
    f = np.asarray(lines)
    fp_ss, hp_ss = peak(f, ss.H)
    hs = harmonic_system(loop.plant, {"a": cfg.plant.frf_point}, F_N1)
    out = {"config": config or "default", "sets": sets, "F_amp_N": F_amp, "F_N1_N": F_N1, "lines_hz": lines,
           "stepsine": {"peak_hz": fp_ss, "peak_abs": hp_ss, "s_per_line": ss_s, "settled": int(ss.settled.sum()),
                        "H_abs": np.abs(ss.H).round(4).tolist(), "thd_max": float(np.nanmax(ss.thd))}}
    for method, nh in METHODS:
        t = time.perf_counter()
        r = harmonic_accelerances(hs, F_amp, f, method=method, n_harm=nh)
        cost = (time.perf_counter() - t) / len(f)
        t = time.perf_counter()
        harmonic_accelerances(hs, F_amp, f, method=method, n_harm=nh, branches=False)
        cost_one = (time.perf_counter() - t) / len(f)
        H = r.H["a"]
        fp, hp = peak(f, H)
        ok = r.converged
        out[f"{method}{nh}"] = {
            "peak_hz": fp, "peak_abs": hp, "peak_f_err_pct": 100 * (fp / fp_ss - 1),
            "peak_db_err": 20 * np.log10(hp / hp_ss),
            "rms_db_err": float(np.sqrt(np.mean((20 * np.log10(np.abs(H[ok] / ss.H[ok]))) ** 2))) if ok.any() else None,
            "converged": int(ok.sum()), "multi": int(np.sum(r.n_solutions > 1)),
            "normal_ratio_max": float(np.nanmax(r.normal_ratio)),
            "s_per_line": cost, "s_per_line_one_start": cost_one, "H_abs": np.abs(H).round(4).tolist()}
    return out


def table(rows: list[dict]) -> str:
    """Markdown table of the comparisons."""
    head = ("| case | F [N] | model | peak [Hz] | peak abs(H) | f err [%] | abs(H) err [dB] | rms err [dB] | "
            "converged | cost/line [s] | one start [s] |\n|---|---|---|---|---|---|---|---|---|---|---|")
    out = [head]
    for r in rows:
        name = r["config"] + ("" if not r["sets"] else " " + ",".join(r["sets"]))
        s = r["stepsine"]
        out.append(f"| {name} | {r['F_amp_N']:g} | step-sine | {s['peak_hz']:.3f} | {s['peak_abs']:.2f} | | | | "
                   f"{s['settled']}/{len(r['lines_hz'])} settled | {s['s_per_line']:.2f} | |")
        for method, nh in METHODS:
            m = r[f"{method}{nh}"]
            rms = "-" if m["rms_db_err"] is None else f"{m['rms_db_err']:.2f}"
            out.append(f"| | | {method} H={nh} | {m['peak_hz']:.3f} | {m['peak_abs']:.2f} | "
                       f"{m['peak_f_err_pct']:+.3f} | {m['peak_db_err']:+.2f} | {rms} | "
                       f"{m['converged']}/{len(r['lines_hz'])} | {m['s_per_line']:.3f} | {m['s_per_line_one_start']:.3f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--json", action="store_true", help="print the rows as JSON instead of the table")
    a = ap.parse_args(argv)
    rows = []
    for name in a.cases:
        config, sets, levels = CASES[name]
        for F_amp, lines, max_s in levels:
            rows.append(compare(config, sets, F_amp, lines, max_s))
            if not a.json:
                print(table(rows[-1:]).split("\n", 2)[-1], flush=True)
    print(json.dumps(rows, indent=1) if a.json else table(rows))
    return 0


if __name__ == "__main__":
    run_main(main)
