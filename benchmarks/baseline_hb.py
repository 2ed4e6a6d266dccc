"""The constant-F_N1 baseline by harmonic balance: each peak from the periodic steady state itself,
a cross-check of benchmarks/baseline_curve's step-sine peaks (issue 15).

    python -m benchmarks.baseline_hb [--out DIR] [--modes 2 3 4 5] [--amps 5 10 20] [--set KEY=VALUE ...]

A step-sine peak is only as good as its grid and its settling (mode 2: zeta ~0.1 %, half-power
band ~0.15 Hz at 71 Hz against the reproduction's 1.2 Hz grid, decay time 1 / (zeta omega) ~2 s);
the harmonic balance (plant.harmonic_frf, "aft", H = 3: the plant's own pair law, contact that
opens and closes) has neither limit, but holds every slider's mean at its static value and keeps
three harmonics (docs/experiments.md compares the two). Per mode, with
(f_slip, f_stuck) of ``frictionrt.rt.experiments.stepsine.mode_bands_hz`` (the plant's own modes), amplitude
and constant F_N1 of ``benchmarks.baseline_curve`` (F_min and ``FORCES``):

1. "df" on ``N_DF`` lines over [0.9 f_slip, 1.01 f_stuck], up in frequency: where the peak is;
2. "aft" on ``N_AFT`` lines of the df spacing centred there, up in frequency; moved by half its
   width (at most ``MOVES`` times) while its maximum lies at an edge;
3. "aft" on ``N_AFT`` lines at a quarter of that spacing around its maximum: the peak is the vertex
   of the parabola through the highest line and its neighbours (``benchmarks.harmonic_frf.peak``).

The same ``one_minimum`` check (0.5 dB) and plot as baseline_curve; a cell where a line did not
converge is marked (crossed in the plot, "*" in the table). Writes ``baseline_hb.json`` and
``baseline_hb.png`` into ``--out`` (default logs/baseline_hb). One BLAS thread, one process:
3-7 s per cell (96 cells: 331 s on the default plant, 637 s with pairs every 10 mm).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from benchmarks.baseline_curve import FORCES, one_minimum, plot, print_table
from benchmarks.harmonic_frf import peak
from frictionrt.plant.harmonic_frf import harmonic_accelerances, harmonic_system
from frictionrt.rt.common.config import load
from frictionrt.rt.experiments.stepsine import mode_bands_hz
from frictionrt.rt.loop import build_loop
from benchmarks.entry import run_main

N_DF, N_AFT, MOVES = 301, 17, 3


def hb_peak(hs, amp_n: float, band: tuple[float, float]) -> dict:
    """The first-harmonic peak of one mode at force amplitude amp_n [N] (module docstring, steps
    1-3): {peak_hz, H_abs [(m/s^2)/N], converged: every aft line converged, at_band_edge}; NaN
    peak where no aft line converged."""
    f_df = np.linspace(band[0], band[1], N_DF)
    a_df = np.abs(harmonic_accelerances(hs, amp_n, f_df, method="df").H["a"])
    df = f_df[1] - f_df[0]
    centre = f_df[int(np.nanargmax(a_df))]
    half = (N_AFT - 1) // 2
    for _ in range(MOVES + 1):
        f = centre + df * np.arange(-half, half + 1)
        r = harmonic_accelerances(hs, amp_n, f, method="aft", branches=False)
        if not r.converged.any():
            return {"peak_hz": float("nan"), "H_abs": float("nan"), "converged": False, "at_band_edge": False}
        k = int(np.nanargmax(np.abs(r.H["a"])))
        if 0 < k < N_AFT - 1:
            break
        centre += df * half * (1 if k else -1)
    ok = bool(r.converged.all())
    f2 = f[k] + 0.25 * df * np.arange(-half, half + 1)
    r2 = harmonic_accelerances(hs, amp_n, f2, method="aft", branches=False)
    fp, hp = peak(f2, r2.H["a"])
    return {"peak_hz": fp, "H_abs": hp, "converged": ok and bool(r2.converged.all()),
            "at_band_edge": not band[0] < fp < band[1]}


def curves_hb(cfg, modes, amps, forces, progress=None) -> dict:
    """mode -> amplitude -> {peaks_by_fn1, settled_by_fn1 (here: converged), peak_hz_by_fn1,
    check (over the forces with a peak)}: the layout of ``benchmarks.baseline_curve.baseline``
    (its plot reads it)."""
    loop = build_loop(cfg, "passive")
    bands = mode_bands_hz(cfg, modes)
    out: dict = {m: {a: {"peaks_by_fn1": {}, "settled_by_fn1": {}, "peak_hz_by_fn1": {}} for a in amps}
                 for m in modes}
    with threadpool_limits(1):
        for fn in forces:
            hs = harmonic_system(loop.plant, {"a": cfg.plant.frf_point}, float(fn))
            for m in modes:
                band = (0.9 * bands[m][0], 1.01 * bands[m][1])
                for a in amps:
                    p = hb_peak(hs, a, band)
                    d = out[m][a]
                    d["peaks_by_fn1"][fn], d["settled_by_fn1"][fn] = p["H_abs"], p["converged"]
                    d["peak_hz_by_fn1"][fn] = p["peak_hz"]
                    if progress is not None:
                        progress(1)
    for m in modes:
        for a in amps:
            d = out[m][a]
            ok = {fn: p for fn, p in d["peaks_by_fn1"].items() if np.isfinite(p)}   # a NaN peak: no aft line converged
            d["check"] = one_minimum(list(ok), list(ok.values()))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--out", default="logs/baseline_hb", help="folder for baseline_hb.json and .png")
    ap.add_argument("--modes", type=int, nargs="+", default=[2, 3, 4, 5], help="bending modes (1 = first)")
    ap.add_argument("--amps", type=float, nargs="+", default=[5.0, 10.0, 20.0], help="force amplitudes [N]")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    cfg = load(None, args.sets)
    forces = sorted({float(cfg.tracking.F_passive_N), *FORCES})
    if any(a <= 0 for a in args.amps):
        ap.error(f"--amps {args.amps}: amplitudes must be > 0 N")
    t0 = time.perf_counter()
    with tqdm(total=len(forces) * len(args.modes) * len(args.amps), unit="cell", desc="baseline_hb",
              file=sys.stderr) as bar:
        curves = curves_hb(cfg, args.modes, args.amps, forces, bar.update)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    doc = {"curves": curves, "sets": args.sets, "method": "aft H=3 (plant.harmonic_frf)",
           "wall_s": time.perf_counter() - t0}
    (out / "baseline_hb.json").write_text(json.dumps(doc, indent=1, default=float))
    plot(curves, str(out / "baseline_hb.png"), ylabel="harmonic-balance peak |H| [dB re 1 (m/s^2)/N]",
         crossed="no convergence")
    print_table(curves, "a line did not converge")
    print(f"written: {out / 'baseline_hb.json'}, {out / 'baseline_hb.png'}; wall {doc['wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    run_main(main)
