"""The constant-F_N1 baseline of the bolted plant: the step-sine peak per clamping force (issue 15).

    python -m benchmarks.baseline_curve [--quick] [--out DIR] [--jobs 2] [--set KEY=VALUE ...]
        [--modes 2 5] [--max-s 8] [--refine-rounds 6]      (a finer measurement of some modes)

The passive law (the stack held at the voltage of ``tracking.F_passive_N``) at each constant F_N1
of ``FORCES`` (40..600 N, F_min = the configured F_passive_N included), modes 2..5, excitation force
amplitudes 5, 10, 20 N: the step-sine FRFs, grids, refinement and peaks of ``frictionrt reproduce``
(``frictionrt.rt.experiments.reproduce.measure`` with the full plan's grid and ``Plan.fn1_n`` = the forces, so the loops
at other forces are ``frictionrt.rt.experiments.reproduce.loop_at_fn1``; the controlled laws run too, and are compared
with the best force). ``--quick``: the reproduction's quick plan (modes 3, 4 at 5 and 20 N, coarse
grid) over the same forces.

Per mode and amplitude ``one_minimum`` decides whether the peak |H| [(m/s^2)/N] over F_N1 falls to
one minimum and rises after it (a minimum at either end counts; wiggles under ``TOL_DB`` = 0.5 dB,
the uncertainty of a peak estimate (rt.experiments.claims), are ignored). Writes into ``--out`` (default
logs/baseline_curve): ``baseline_curve.json`` (per mode and amplitude: F_N1 -> peak, the check,
each law's peak against the best force; the reproduction's claims; the plan; wall time) and
``baseline_curve.png`` (peak [dB] against F_N1 (log axis), one panel per mode, one line per
amplitude).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from frictionrt.rt.experiments.claims import TOL_DB
from frictionrt.rt.common.config import load
from frictionrt.rt.experiments.reproduce import FULL, QUICK, measure, peak
from frictionrt.rt.experiments.reproduce_report import jsonable
from benchmarks.entry import run_main

# constant F_N1 [N] besides the configured F_passive_N (F_min = 40 N): from F_min to F_max = 600 N,
# roughly log-spaced (ratios 1.3..2), denser where the earlier plant had its minima (120..320 N)
FORCES = (80.0, 120.0, 160.0, 240.0, 320.0, 450.0, 600.0)


def one_minimum(fn1_n: Sequence[float], peaks: Sequence[float], tol_db: float = TOL_DB) -> dict:
    """Does the peak fall to one minimum and rise after it? A pure function.

    With p_i = 20 log10(peaks_i) [dB] in the order of increasing fn1_n [N] and m the index of the
    smallest peak: holds if no point before m rises more than tol_db [dB] above the lowest point
    before it (max_{j<k<=m} p_k - p_j <= tol_db) and no point after m falls more than tol_db below
    the highest point between m and it (max_{m<=j<k} p_j - p_k <= tol_db). A minimum at the first
    or last force counts (then one side is empty).

    Returns {"holds", "fn1_min_n": fn1_n at m, "peak_min": peaks_m, "worst_wiggle_db": the larger
    of the two maxima above (<= tol_db when it holds; 0 for a strictly monotone side),
    "at_n": the F_N1 of the point where that worst wiggle ends, "tol_db"}."""
    if len(fn1_n) != len(peaks) or len(fn1_n) < 2:
        raise ValueError(f"{len(fn1_n)} forces and {len(peaks)} peaks: give at least two of each, as many")
    if not all(p > 0 and math.isfinite(p) for p in peaks):
        raise ValueError(f"peaks {list(peaks)}: must be finite and > 0")
    order = sorted(range(len(fn1_n)), key=lambda i: fn1_n[i])
    f = [float(fn1_n[i]) for i in order]
    p = [20.0 * math.log10(peaks[i]) for i in order]
    m = min(range(len(p)), key=lambda i: p[i])
    worst, at = 0.0, f[m]
    low = p[0]                       # falling side: the lowest point so far
    for k in range(1, m + 1):
        if p[k] - low > worst:
            worst, at = p[k] - low, f[k]
        low = min(low, p[k])
    high = p[m]                      # rising side: the highest point so far
    for k in range(m + 1, len(p)):
        if high - p[k] > worst:
            worst, at = high - p[k], f[k]
        high = max(high, p[k])
    return {"holds": worst <= tol_db, "fn1_min_n": f[m], "peak_min": float(peaks[order[m]]),
            "worst_wiggle_db": worst, "at_n": at, "tol_db": tol_db}


def baseline(result: dict, dt: float, tol_db: float = TOL_DB) -> dict:
    """mode -> amplitude -> {peaks_by_fn1: F_N1 [N] -> peak [(m/s^2)/N], settled_by_fn1 and
    edge_by_fn1: F_N1 -> whether that peak's point settled / lies at the grid's edge, the
    ``one_minimum`` check, and per controlled law {H_abs, vs_best_db}} from ``frictionrt.rt.experiments.reproduce.measure``'s
    result (its passive FRFs, dt [s] the controller step, and the report's ``best_passive_fn1``)."""
    fn1_passive = result["report"]["plan"]["fn1_n"][0]   # the passive law as configured: F_passive_N
    out: dict = {}
    for k, r in result["frfs"].items():
        if k.law == "passive":
            p = peak(r, dt)
            d = out.setdefault(k.mode, {}).setdefault(k.amp_n, {"peaks_by_fn1": {}, "settled_by_fn1": {},
                                                                "edge_by_fn1": {}})
            f = float(fn1_passive if k.fn1_n is None else k.fn1_n)
            d["peaks_by_fn1"][f], d["settled_by_fn1"][f] = p["H_abs"], p["settled"]
            d["edge_by_fn1"][f] = p["at_band_edge"]
    best = result["report"]["best_passive_fn1"]
    for m, by_amp in out.items():
        for a, d in by_amp.items():
            for name in ("peaks_by_fn1", "settled_by_fn1", "edge_by_fn1"):
                d[name] = dict(sorted(d[name].items()))
            d["check"] = one_minimum(list(d["peaks_by_fn1"]), list(d["peaks_by_fn1"].values()), tol_db)
            d |= {law: best[m][a][law] for law in ("hysteresis", "lyapunov")}
    return dict(sorted((m, dict(sorted(v.items()))) for m, v in out.items()))


def plot(curves: dict, path: str, ylabel: str = "step-sine peak |H| [dB re 1 (m/s^2)/N]",
         crossed: str = "not settled") -> None:
    """Peak |H| [dB re 1 (m/s^2)/N] against F_N1 [N] (log axis), one panel per mode, one line per
    amplitude; the minimum ringed, filled if the one-minimum check holds; a peak whose
    ``settled_by_fn1`` is False crossed (``crossed`` says what that means). PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter, ScalarFormatter
    modes = sorted(curves)
    fig, axes = plt.subplots(1, len(modes), figsize=(3.3 * len(modes), 3.3), squeeze=False)
    for ax, m in zip(axes[0], modes):
        for a in sorted(curves[m]):
            c = curves[m][a]
            fs = list(c["peaks_by_fn1"])
            ps = [20.0 * math.log10(c["peaks_by_fn1"][x]) for x in fs]
            line, = ax.plot(fs, ps, marker=".", lw=1.0, label=f"{a:g} N")
            bad = [(x, p) for x, p in zip(fs, ps) if not c["settled_by_fn1"][x]]
            if bad:
                ax.plot(*zip(*bad), "x", ms=6, color=line.get_color())
            ok = c["check"]["holds"]
            ax.plot(c["check"]["fn1_min_n"], 20.0 * math.log10(c["check"]["peak_min"]), "o", ms=8,
                    color=line.get_color(), mfc=line.get_color() if ok else "none", alpha=0.6)
        ax.set_xscale("log")
        ax.set_xticks(fs)
        ax.tick_params(axis="x", labelrotation=90, labelsize=7)
        ax.tick_params(axis="y", labelsize=7)
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(f"mode {m}", fontsize=9)
        ax.set_xlabel("constant F_N1 [N]", fontsize=8)
        ax.grid(True, which="both", lw=0.3)
    axes[0][0].set_ylabel(ylabel, fontsize=8)
    axes[0][-1].legend(fontsize=7, title="amplitude", title_fontsize=7)
    fig.suptitle("passive law at constant F_N1: peak |a(0.45 m) / F_exc|\n(ring: minimum, filled: one minimum "
                 f"within 0.5 dB; x: {crossed})", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def print_table(curves: dict, starred: str) -> None:
    """One line per mode and amplitude: the check, the minimum, the peaks per F_N1 ("*": the
    peak's ``settled_by_fn1`` is False, which ``starred`` names), the worst wiggle."""
    print(f"{'mode':>4} {'amp':>5} {'one min':>7} {'at':>6}  peaks per F_N1 [(m/s^2)/N] (*: {starred})")
    for m, by_amp in curves.items():
        for a, c in by_amp.items():
            ch = c["check"]
            peaks = ", ".join(f"{x:g}: {v:.3g}" + ("" if c["settled_by_fn1"][x] else "*")
                              for x, v in c["peaks_by_fn1"].items())
            print(f"{m:>4} {a:>5g} {'yes' if ch['holds'] else 'NO':>7} {ch['fn1_min_n']:>6g}  {peaks}"
                  f"  (worst wiggle {ch['worst_wiggle_db']:.2f} dB at {ch['at_n']:g} N)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="the reproduction's quick plan: modes 3, 4 at 5 and 20 N")
    ap.add_argument("--out", default="logs/baseline_curve", help="folder for baseline_curve.json and .png")
    ap.add_argument("--jobs", type=int, default=None, help="local worker processes (default: the cores)")
    ap.add_argument("--modes", type=int, nargs="+", help="these modes only (default: the plan's)")
    ap.add_argument("--max-s", type=float, help="simulated time per point before giving up [s] (default: the plan's)")
    ap.add_argument("--refine-rounds", type=int, help="refinement rounds at most (default: the plan's)")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    cfg = load(None, args.sets)
    plan = dataclasses.replace(QUICK if args.quick else FULL, fn1_n=FORCES)
    if args.modes:
        plan = dataclasses.replace(plan, modes=tuple(args.modes))
    if args.max_s:
        plan = dataclasses.replace(plan, settle=dataclasses.replace(plan.settle, max_s=args.max_s))
    if args.refine_rounds is not None:
        plan = dataclasses.replace(plan, refine_rounds=args.refine_rounds)
    t0 = time.perf_counter()
    result = measure(cfg, plan, jobs=args.jobs, stage=lambda text: print(f"baseline: {text}", file=sys.stderr))
    curves = baseline(result, cfg.dt_s)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    doc = {"curves": curves, "claims": {c: v["holds"] for c, v in result["report"]["claims"].items()},
           "peak_change_db": result["report"]["peak_change_db"], "plan": result["report"]["plan"],
           "sets": args.sets, "wall_s": time.perf_counter() - t0}
    (out / "baseline_curve.json").write_text(json.dumps(jsonable(doc), indent=1))
    plot(curves, str(out / "baseline_curve.png"))
    print_table(curves, "not settled")
    print(f"written: {out / 'baseline_curve.json'}, {out / 'baseline_curve.png'}; wall {doc['wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    run_main(main)
