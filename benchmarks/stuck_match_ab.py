"""The stuck period matching (plant.period_match_stuck) against the open-contact one at one substep,
per step scheme, against one reference per case (docs/plant.md 2.9).

    python -m benchmarks.stuck_match_ab [--substeps 1] [--fn1 40 100] [--linear] [--set KEY=VALUE ...]

Per hammer level F_N1 and case (slipping: the configured mu; stuck: mu = 2) the default plant's
simulated hammer test (benchmarks.joint_convergence.hammer, 50 N, 2 s) runs once with the trapezoid
at 64 substeps (the reference: the two schemes' 64-substep FRFs agree to -58..-64 dB, docs/plant.md
2.8, far below the errors compared here), then per scheme and matching at the given substeps.
Printed: the FRF error weighted by the reference over 50-1200 Hz and per band of modes 2-5 [dB].
With --linear also the linear stuck case (mu = 2, a 1 N hammer at 300 N: no pair changes state),
with the weighted error over 900-1200 Hz and the largest offset line [Hz, dB] beside it. The runs
are sequential (one process).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.entry import run_main
from benchmarks.joint_convergence import hammer
from frictionrt.plant import measures
from frictionrt.rt.common.config import STEP_SCHEMES, load, with_sets

CASES = (("slipping", []), ("stuck", ["plant.interface.mu=2.0"]))
MATCHING = (("open", "false"), ("stuck", "true"))


def rows(cfg, F_N1: float, substeps: int, extra: bool) -> None:
    """The reference, then one table row per scheme and matching."""
    t0 = time.perf_counter()
    ref = hammer(with_sets(cfg, ["plant.substeps=64", "plant.step_scheme=trapezoidal"]), F_N1)
    bands = measures.mode_bands(ref["f"])
    hi = (ref["freq"] >= 900.0) & (ref["freq"] <= 1200.0)
    for scheme in STEP_SCHEMES:
        for name, on in MATCHING:
            r = hammer(with_sets(cfg, [f"plant.substeps={substeps}", f"plant.step_scheme={scheme}",
                                       f"plant.period_match_stuck={on}"]), F_N1)
            be = measures.band_errors_db(r["freq"], r["H"], ref["H"], bands)
            cells = [f"{measures.weighted_error_db(r['H'], ref['H']):.1f}", ", ".join(f"{b:.1f}" for b in be)]
            if extra:
                d = 20 * np.log10(np.abs(r["H"]) / np.abs(ref["H"]))
                k = int(np.argmax(np.abs(d)))
                cells += [f"{measures.weighted_error_db(r['H'][hi], ref['H'][hi]):.1f}",
                          f"{measures.rms_db(r['H'], ref['H']):.2f}", f"{r['freq'][k]:.1f}, {d[k]:+.1f}"]
            print(f"| {scheme} | {name} | " + " | ".join(cells) + " |", flush=True)
    print(f"\n(wall {time.perf_counter() - t0:.0f} s)", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--substeps", type=int, default=1, help="the compared runs' substeps (default 1)")
    ap.add_argument("--fn1", type=float, nargs="*", default=[40.0, 100.0], help="F_N1 levels [N] (default 40 100)")
    ap.add_argument("--cases", nargs="+", default=[c for c, _ in CASES], choices=[c for c, _ in CASES])
    ap.add_argument("--linear", action="store_true", help="also the linear stuck case (300 N, 1 N hammer, mu 2)")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    if args.substeps < 1:
        ap.error(f"--substeps {args.substeps}: give a positive count")
    base = load(None, args.sets)
    head = "| scheme | matching | weighted [dB] | modes 2-5's bands [dB] |"
    if args.linear:
        print(f"\n## Linear stuck case (mu 2, 1 N hammer, 300 N), {args.substeps} substep(s) against the trapezoid "
              "at 64\n")
        print(head + " 900-1200 Hz [dB] | rms of dB | largest line [Hz, dB] |")
        print("| --- | --- | --- | --- | --- | --- | --- |", flush=True)
        rows(with_sets(base, ["plant.interface.mu=2.0", "impulse.peak_N=1.0"]), 300.0, args.substeps, True)
    for F_N1 in args.fn1:
        for case, sets in CASES:
            if case not in args.cases:
                continue
            print(f"\n## F_N1 = {F_N1:g} N, {case}, {args.substeps} substep(s) against the trapezoid at 64\n")
            print(head)
            print("| --- | --- | --- | --- |", flush=True)
            rows(with_sets(base, sets), F_N1, args.substeps, False)
    return 0


if __name__ == "__main__":
    run_main(main)
