"""Why a claim fails: the measured mechanism behind each failing cell of a reproduction (issue 32 item 4).

    python -m benchmarks.claim_mechanisms REPORT.json [--duration 1.0] [--set KEY=VALUE ...]
                                          [--cell LAW,MODE,AMP ...] [--json]

The cells that make C3 or C4 fail on an estimator of ``report.json`` (``frictionrt reproduce``;
give the same ``--set`` as the run): for C3, the cells of a law that reduces fewer than two modes
at every amplitude where its reduction is above -0.5 dB; for C4, the cells at the smallest amplitude
above +0.5 dB (rt.experiments.claims); ``--cell`` names cells to run whatever their verdict (claim
"-"; e.g. a sensitivity variant's cell whose verdict flipped, from ``reproduce --modes``). Each is
run once more: the law, on that estimator, at the
cell's peak frequency and amplitude for ``--duration`` s, steady state over the last half:

* ``u0_um``: the RT1 amplitude u0 [um] (mean), and ``Kf_u0_over_Fmin`` = K_f u0 / F_min: below 1 the
  hysteresis law's setpoint K_f u0 (Eq. 3) saturates at F_min, so the law is the passive law;
* ``F_set_mean_n``, ``F_N1_mean_n`` [N], ``at_F_max``: the share of ticks with F_set at F_max;
* ``F_set_2f_n``, ``F_N1_2f_n``: the amplitudes [N] at twice the excitation frequency, the rate at
  which the Lyapunov law switches, and ``transmitted`` = F_N1_2f / F_set_2f: the share of the law's
  switching the force tracking, the output low-pass and the stack pass on to the screw (NaN where
  F_set's is below 1 N: the law holds its force);
* ``constant_clamp_peak``: the passive peak |H| [(m/s^2)/N] at a constant F_N1 equal to the law's
  mean F_N1, interpolated (linear in F_N1) in the report's baseline ``peaks_by_fn1``, beside the
  law's own peak: equal, the law acts as a constant clamp at its mean force.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmarks.entry import run_main
from frictionrt.rt.common.config import load
from frictionrt.rt.experiments.mechanisms import failing_cells, mechanism
from frictionrt.rt.loop import Designs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("report", type=Path, help="report.json of frictionrt reproduce")
    ap.add_argument("--duration", type=float, default=1.0, help="simulated time per cell [s]")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE",
                    help="the --set of the reproduction (its gains)")
    ap.add_argument("--cell", action="append", default=[], metavar="LAW,MODE,AMP",
                    help="run this cell too, on every estimator of the report (e.g. lyapunov,5,5)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    report = json.loads(args.report.read_text())
    if "by_estimator" not in report:
        raise SystemExit(f"{args.report}: no by_estimator (a report of frictionrt reproduce before issue 32); "
                         "run the reproduction again")
    cfg, designs = load(None, args.sets), Designs()
    cells = failing_cells(report["by_estimator"])
    for text in args.cell:
        parts = text.split(",")
        peaks = next(iter(report["by_estimator"].values()))["peaks"]
        try:
            law, mode, amp = parts
            peaks[law][mode][f"{float(amp):g}"]
        except (ValueError, KeyError):
            raise SystemExit(f"--cell {text}: give LAW,MODE,AMP of a cell in {args.report}, e.g. lyapunov,5,5")
        cells += [{"estimator": est, "claim": "-", "law": law, "mode": mode, "amp": f"{float(amp):g}"}
                  for est in report["by_estimator"]]
    rows = [mechanism(cfg, designs, c, report, args.duration) for c in cells]
    if args.json:
        print(json.dumps(rows))
        return 0
    print("| claim | estimator | law | mode | F [N] | f [Hz] | reduction [dB] | u0 [um] | K_f u0 / F_min (hysteresis) "
          "| mean F_set / F_N1 [N] "
          "| at F_max | 2f: F_set / F_N1 [N] (transmitted) | peak / constant clamp at mean F_N1 |")
    print("| --- " * 13 + "|")
    for r in rows:
        print(f"| {r['claim']} | {r['estimator']} | {r['law']} | {r['mode']} | {r['amp']} | {r['f_hz']:.2f} | "
              f"{r['reduction_db']:+.2f} | {r['u0_um']:.3f} | "
              f"{format(r['Kf_u0_over_Fmin'], '.2f') if r['law'] == 'hysteresis' else '-'} | {r['F_set_mean_n']:.0f} / "
              f"{r['F_N1_mean_n']:.0f} | {r['at_F_max']:.2f} | {r['F_set_2f_n']:.1f} / {r['F_N1_2f_n']:.1f} "
              f"({'-' if np.isnan(r['transmitted']) else format(r['transmitted'], '.2f')}) | {r['peak']:.3g} / "
              f"{r['constant_clamp_peak']:.3g} |")
    return 0


if __name__ == "__main__":
    run_main(main)
