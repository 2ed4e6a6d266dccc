"""Store the margins `frictionrt reproduce --error-estimate auto` takes for a configuration and plan
(rt/experiments/discretisation.py, rt/experiments/coarse_margins.json).

    python -m benchmarks.coarse_margins [--full] [--jobs N] [--set KEY=VALUE ...]

Runs the plan (--quick's, or the full one with --full) on the plant with the contact pitch and the
element length doubled and on the plant with twice the substeps, and the impulse test on the
refined plant (pitch and elements halved, substeps x 4), and stores the three runs' margins under
the key of the configuration (with the --set),
the plan and the kernel version. Run it again after a change of the configuration's defaults, the
plans or the kernel version: the key changes with each, and a reproduction without a record pays
for both runs itself (tests/test_reproduce.py's quick run checks that the default's is stored).
"""
from __future__ import annotations

import argparse
import time

from benchmarks.entry import run_main
from frictionrt.rt.common.config import load
from frictionrt.rt.experiments.discretisation import (ErrorEstimate, coarser, halved_step, margins, record_key,
                                                      refined_impulse_margins, store)
from frictionrt.rt.experiments.reproduce import FULL, QUICK, measure


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--full", action="store_true", help="the full plan (default: --quick's)")
    ap.add_argument("--jobs", type=int, default=None, help="local worker processes (default: the cores)")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    cfg, plan = load(None, args.sets), FULL if args.full else QUICK
    t0 = time.perf_counter()
    fine = refined_impulse_margins(cfg, plan.impulse_fn1_n)
    c = measure(coarser(cfg), plan, jobs=args.jobs, error_estimate=ErrorEstimate.NONE, explain=False)
    coarse = {est: margins(v["claims"]) for est, v in c["report"]["by_estimator"].items()}
    h = measure(halved_step(cfg), plan, jobs=args.jobs, error_estimate=ErrorEstimate.NONE, explain=False)
    half = {est: margins(v["claims"]) for est, v in h["report"]["by_estimator"].items()}
    store(cfg, plan, coarse, f"coarse_margins: the {'full' if args.full else 'quick'} plan with the pitch and "
          f"elements x2; half_step_margins: the same plan with the substeps x2; refined_margins: the impulse test "
          f"on the refined plant; --set {args.sets}", refined_margins=fine, half_step=half)
    print(f"stored {record_key(cfg, plan)}: coarse {coarse}, half step {half}, refined {fine} "
          f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    run_main(main)
