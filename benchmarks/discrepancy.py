"""Confusion table of the discrepancy workflow (docs/discrepancy.md): for every implemented effect
of rt.effects at its moderate (default) strength and at twice it, and for no effect, a rig campaign
(seed SEED) is diagnosed; printed as a markdown table (hidden effect, strength, named effect,
fitted strength, dBIC over calibration alone, structure FRF gap and actuator NRMSE before -> after).

    .venv/bin/python -m benchmarks.discrepancy [SEED] [--record-s 1.0]   (-m: benchmarks/plant.py would shadow the plant package)
"""
import argparse
import tempfile
import time
from pathlib import Path

from rt.diagnose import diagnose
from rt.effects import implemented
from rt.rig import make_campaign


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("seed", type=int, nargs="?", default=11)
    ap.add_argument("--record-s", type=float, default=1.0)
    args = ap.parse_args()
    cases = [("none", None)] + [(e.name, e.parameter.default * f) for e in implemented() for f in (1.0, 2.0)]
    if "current_limit" in [c[0] for c in cases]:   # "twice as strong" = half the limit
        cases = [(n, (s if n != "current_limit" else (0.3 if s == 0.3 else 0.15))) for n, s in cases]
    print("| hidden effect | strength | named | fitted | dBIC | runner-up | FRF gap [dB] before -> after | "
          "actuator NRMSE before -> after | s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, s in cases:
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as d:
            make_campaign(Path(d) / "c", name, s, seed=args.seed, record_s=args.record_s)
            r = diagnose(Path(d) / "c")
        top = r["ranking"][0]
        fitted = r["fitted_parameters"].get(r["named_effect"], "") if r["named_effect"] else ""
        gb, ga = r["gap_before"], r["gap_after"]
        print(f"| {name} | {'' if s is None else f'{s:g}'} | {r['named_effect'] or '-'} | "
              f"{fitted if fitted == '' else f'{fitted:.4g}'} | {top['delta_bic']:.1f} ({top['effect']}) | "
              f"{r['runner_up']} | {gb['structure_frf_db']:.2f} -> {ga['structure_frf_db']:.2f} | "
              f"{gb['actuator_nrmse']:.4f} -> {ga['actuator_nrmse']:.4f} | {time.perf_counter() - t0:.0f} |",
              flush=True)


if __name__ == "__main__":
    main()
