"""The plant step's observed order, one scheme against another in the same run (docs/plant.md 2.8).

    python -m benchmarks.step_order [--substeps 1 2 4 8 64] [--fn1 40 100]
                                    [--schemes trapezoidal generalized_alpha] [--set KEY=VALUE ...]
    python -m benchmarks.step_order --rho 0.5 0.65 0.8 0.9 [--substeps 1 2 64] [--fn1 40 100]

Per hammer level F_N1, per case (slipping: the configured mu; stuck: mu = 2) and per step scheme
(plant.step_scheme) the default plant's simulated hammer test (benchmarks.joint_convergence.hammer,
the configured 50 N hammer, 2 s record) is run at each number of substeps; the last is the
reference. Printed per scheme and substeps: the FRF error weighted by the reference's magnitude
(plant.measures.weighted_error_db) over 50-1200 Hz and per band of modes 2-5 [dB], the rms of dB,
and the observed order between successive halvings, p = (e_S - e_2S) / 6.02; then the distance
between the schemes' references (their limits are the same model). Figures with the case's wall
time; the runs are sequential (one process). With --rho: generalized-alpha at each spectral radius
plant.step_rho_inf and each substeps count but the last, against its rho = 0.8 run at the last.
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
DB2 = 20.0 * np.log10(2.0)


def errors(rows: dict[int, dict], ref: dict) -> dict[int, dict]:
    """Per substeps: weighted error over the band and per mode band [dB], rms of dB, against ref."""
    bands = measures.mode_bands(ref["f"])
    return {s: {"weighted_db": measures.weighted_error_db(r["H"], ref["H"]),
                "band_db": measures.band_errors_db(r["freq"], r["H"], ref["H"], bands),
                "rms_db": measures.rms_db(r["H"], ref["H"])} for s, r in rows.items()}


def rho_sweep(base, args, subs, s_ref) -> int:
    """Generalized-alpha's weighted error [dB] per rho_inf and substeps against rho_inf = 0.8 at s_ref."""
    for F_N1 in args.fn1:
        for case, case_sets in CASES:
            if case not in args.cases:
                continue
            cfg = with_sets(base, case_sets + ["plant.step_scheme=generalized_alpha"])
            ref = hammer(with_sets(cfg, ["plant.step_rho_inf=0.8", f"plant.substeps={s_ref}"]), F_N1)
            print(f"\n## F_N1 = {F_N1:g} N, {case}: generalized-alpha's weighted error [dB] (modes 2-5's bands) "
                  f"against rho_inf 0.8 at {s_ref} substeps\n")
            print("| rho_inf | " + " | ".join(f"{s}" for s in subs) + " |")
            print("| --- |" + " --- |" * len(subs), flush=True)
            for rho in args.rho:
                rows = {s: hammer(with_sets(cfg, [f"plant.step_rho_inf={rho}", f"plant.substeps={s}"]), F_N1)
                        for s in subs}
                e = errors(rows, ref)
                cells = [f"{e[s]['weighted_db']:.1f} ({', '.join(f'{b:.1f}' for b in e[s]['band_db'])})" for s in subs]
                print(f"| {rho:g} | " + " | ".join(cells) + " |", flush=True)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--substeps", type=int, nargs="+", default=[1, 2, 4, 8, 64],
                    help="substeps per controller step, the last the reference (default 1 2 4 8 64)")
    ap.add_argument("--fn1", type=float, nargs="+", default=[40.0, 100.0], help="F_N1 levels [N] (default 40 100)")
    ap.add_argument("--schemes", nargs="+", default=list(STEP_SCHEMES), choices=STEP_SCHEMES)
    ap.add_argument("--cases", nargs="+", default=[c for c, _ in CASES], choices=[c for c, _ in CASES])
    ap.add_argument("--rho", type=float, nargs="+", default=None, help="generalized-alpha's rho_inf sweep")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    if sorted(args.substeps) != args.substeps or args.substeps[0] < 1 or len(args.substeps) < 2:
        ap.error(f"--substeps {args.substeps}: give two or more increasing positive counts, the reference last")
    base = load(None, args.sets)
    subs, s_ref = args.substeps[:-1], args.substeps[-1]
    if args.rho:
        return rho_sweep(base, args, subs, s_ref)
    for F_N1 in args.fn1:
        for case, case_sets in CASES:
            if case not in args.cases:
                continue
            refs = {}
            print(f"\n## F_N1 = {F_N1:g} N, {case}: weighted error [dB] (modes 2-5's bands) / rms of dB, "
                  f"against {s_ref} substeps of the same scheme\n")
            print("| scheme | " + " | ".join(f"{s}" for s in subs) + " | observed order (weighted) | wall [s] |")
            print("| --- |" + " --- |" * (len(subs) + 2), flush=True)
            for scheme in args.schemes:
                t0 = time.perf_counter()
                cfg = with_sets(base, case_sets + [f"plant.step_scheme={scheme}"])
                rows = {s: hammer(with_sets(cfg, [f"plant.substeps={s}"]), F_N1) for s in args.substeps}
                refs[scheme] = rows[s_ref]
                e = errors({s: rows[s] for s in subs}, rows[s_ref])
                cells = [f"{e[s]['weighted_db']:.1f} ({', '.join(f'{b:.1f}' for b in e[s]['band_db'])}) / "
                         f"{e[s]['rms_db']:.2f}" for s in subs]
                orders = [(e[a]["weighted_db"] - e[b]["weighted_db"]) / DB2 / np.log2(b / a)
                          for a, b in zip(subs, subs[1:])]
                print(f"| {scheme} | " + " | ".join(cells) + " | " + ", ".join(f"{p:.2f}" for p in orders)
                      + f" | {time.perf_counter() - t0:.0f} |", flush=True)
            if len(refs) == 2:
                a, b = (refs[s] for s in args.schemes)
                print(f"\nthe references' distance ({args.schemes[0]} against {args.schemes[1]}, {s_ref} substeps): "
                      f"weighted {measures.weighted_error_db(a['H'], b['H']):.1f} dB, "
                      f"rms {measures.rms_db(a['H'], b['H']):.3f} dB", flush=True)
    return 0


if __name__ == "__main__":
    run_main(main)
