"""Confusion table of the discrepancy workflow (docs/discrepancy.md): for every implemented effect
of rt.effects at its moderate (default) strength and at half of it (half its departure from the
nominal value: current_limit 1 A -> 0.65 A), and for no effect, a rig campaign (seed SEED) is
diagnosed; printed as a markdown table (hidden effect, strength, named effect, fitted strength and
its error, dBIC and RSS reduction of the best candidate, runner-up, structure FRF gap and actuator
NRMSE before -> after, seconds).

    .venv/bin/python -m benchmarks.discrepancy [SEED ...] [--record-s 1.0]   (-m: benchmarks/plant.py would shadow the plant package)
"""
import argparse
import tempfile
import time
from pathlib import Path

from rt.diagnose import diagnose
from rt.effects import get, implemented
from rt.rig import make_campaign


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("seeds", type=int, nargs="*", default=[11])
    ap.add_argument("--record-s", type=float, default=1.0)
    args = ap.parse_args()
    cases = [("none", None)] + [(e.name, e.nominal + f * (e.parameter.default - e.nominal))
                                for e in implemented() for f in (1.0, 0.5)]
    print("| seed | hidden effect | strength | named | fitted (error) | best: dBIC, RSS reduction | runner-up | "
          "FRF gap [dB] before -> after | actuator NRMSE before -> after | step-sine F_amp/drive gap [dB] | s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for seed in args.seeds:
        for name, s in cases:
            t0 = time.perf_counter()
            with tempfile.TemporaryDirectory() as d:
                make_campaign(Path(d) / "c", name, s, seed=seed, record_s=args.record_s,
                              stepsine=name != "none" and get(name).channel == "stepsine")
                r = diagnose(Path(d) / "c")
            top = r["ranking"][0]
            named = r["named_effect"]
            fitted = ""
            if named:
                v = r["fitted_parameters"][named]
                fitted = f"{v:.4g}" + (f" ({100 * (v - s) / (s - get(name).nominal):+.1f} %)" if named == name else "")
            gb, ga = r["gap_before"], r["gap_after"]
            print(f"| {seed} | {name} | {'' if s is None else f'{s:g}'} | {named or '-'} | {fitted} | "
                  f"{top['effect']}: {top['delta_bic']:.1f}, {100 * top['rss_reduction']:.1f} % | {r['runner_up']} | "
                  f"{gb['structure_frf_db']:.2f} -> {ga['structure_frf_db']:.2f} | "
                  f"{gb['actuator_nrmse']:.4f} -> {ga['actuator_nrmse']:.4f} | "
                  + (f"{gb['stepsine_ratio_db']:.2f} -> {ga['stepsine_ratio_db']:.2f}" if "stepsine_ratio_db" in gb else "")
                  + f" | {time.perf_counter() - t0:.0f} |",
                  flush=True)


if __name__ == "__main__":
    main()
