"""Two reproductions side by side: claims and peak reductions of two ``frictionrt reproduce`` reports.

    python -m benchmarks.report_diff A/report.json B/report.json [--names A B] [--baseline baseline_curve.json]

Prints the claims C1..C6 of both (holds yes/NO, "same" or "DIFFERS"), every peak reduction [dB]
of both with B - A, the largest |B - A| of a peak reduction and the largest relative difference
of a peak |H| (every FRF of the report's ``peaks`` and ``best_passive_fn1``). With ``--baseline``
(a benchmarks.baseline_curve JSON) also each law's peak against the best constant F_N1 of that
baseline, 20 log10(peak_law / best) [dB]. Used for the two code generations and the gains of
docs/experiments.md.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path


def cells(red: dict) -> dict:
    """(law, mode, amplitude [N]) -> value from a JSON law -> mode -> amplitude table."""
    return {(law, int(m), float(a)): v for law, by_m in red.items() for m, by_a in by_m.items()
            for a, v in by_a.items()}


def peaks(report: dict) -> dict:
    """(law, F_N1 [N] or None, mode, amplitude [N]) -> peak |H| [(m/s^2)/N]: the laws' peaks and
    the passive law's at every constant F_N1."""
    out = {(law, None, m, a): p["H_abs"] for (law, m, a), p in cells(report["peaks"]).items()}
    for m, by_a in report["best_passive_fn1"].items():
        for a, d in by_a.items():
            for f, p in d["peaks_by_fn1"].items():
                out[("passive", float(f), int(m), float(a))] = p
    return out


def diff(a: dict, b: dict) -> dict:
    """{claims: C -> (holds_a, holds_b), reduction: (law, mode, amp) -> (dB_a, dB_b),
    max_reduction_diff_db: (|b - a|, its cell), max_peak_rel: (|b/a - 1|, its FRF)} of two reports."""
    ra, rb = cells(a["peak_change_db"]), cells(b["peak_change_db"])
    red = {k: (ra[k], rb.get(k)) for k in ra}
    dk = max((k for k in red if None not in red[k]), key=lambda k: abs(red[k][1] - red[k][0]))
    pa, pb = peaks(a), peaks(b)
    common = [k for k in pa if k in pb]
    pk = max(common, key=lambda k: abs(pb[k] / pa[k] - 1.0))
    return {"claims": {c: (a["claims"][c]["holds"], b["claims"][c]["holds"]) for c in a["claims"]},
            "reduction": red, "max_reduction_diff_db": (abs(red[dk][1] - red[dk][0]), dk),
            "max_peak_rel": (abs(pb[pk] / pa[pk] - 1.0), pk), "peaks_compared": len(common)}


def vs_best(report: dict, curves: dict) -> dict:
    """(law, mode, amplitude [N]) -> 20 log10(the law's peak / the lowest constant-F_N1 peak of
    the baseline's curves at that mode and amplitude) [dB]; cells the baseline lacks are left out."""
    best = {(int(m), float(a)): min(c["peaks_by_fn1"].values())
            for m, by_a in curves.items() for a, c in by_a.items()}
    return {(law, m, a): 20.0 * math.log10(p["H_abs"] / best[(m, a)])
            for (law, m, a), p in cells(report["peaks"]).items() if law != "passive" and (m, a) in best}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a", help="report.json of the first reproduction")
    ap.add_argument("b", help="report.json of the second")
    ap.add_argument("--names", nargs=2, default=["A", "B"])
    ap.add_argument("--baseline", metavar="JSON",
                    help="a benchmarks.baseline_curve JSON: each law against its best constant F_N1")
    args = ap.parse_args(argv)
    na, nb = args.names
    a, b = json.loads(Path(args.a).read_text()), json.loads(Path(args.b).read_text())
    d = diff(a, b)
    yn = lambda h: "yes" if h else "NO"
    print(f"| claim | {na} | {nb} | |\n| --- | --- | --- | --- |")
    for c, (ha, hb) in d["claims"].items():
        print(f"| {c} | {yn(ha)} | {yn(hb)} | {'same' if ha == hb else '**DIFFERS**'} |")
    print(f"\n| law | mode | amplitude [N] | {na} [dB] | {nb} [dB] | {nb} - {na} [dB] |")
    print("| --- | --- | --- | --- | --- | --- |")
    for (law, m, amp), (x, y) in d["reduction"].items():
        print(f"| {law} | {m} | {amp:g} | {x:+.2f} | " + ("- | - |" if y is None else f"{y:+.2f} | {y - x:+.3f} |"))
    v, k = d["max_reduction_diff_db"]
    print(f"\nlargest |{nb} - {na}| of a peak reduction: {v:.3g} dB ({k[0]}, mode {k[1]}, {k[2]:g} N)")
    v, k = d["max_peak_rel"]
    fn1 = "as configured" if k[1] is None else f"F_N1 = {k[1]:g} N"
    print(f"largest relative difference of a peak |H| over {d['peaks_compared']} FRFs: {v:.3g} "
          f"({k[0]} {fn1}, mode {k[2]}, {k[3]:g} N)")
    if args.baseline:
        curves = json.loads(Path(args.baseline).read_text())["curves"]
        va, vb = vs_best(a, curves), vs_best(b, curves)
        print(f"\nagainst the best constant F_N1 of {args.baseline} [dB] (negative: the law wins)")
        print(f"| law | mode | amplitude [N] | {na} | {nb} |\n| --- | --- | --- | --- | --- |")
        for k, x in va.items():
            y = vb.get(k)
            print(f"| {k[0]} | {k[1]} | {k[2]:g} | {x:+.2f} | " + ("-" if y is None else f"{y:+.2f}") + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
