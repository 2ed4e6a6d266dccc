"""Observer accuracy table (docs/observer.md sections 6 and 10): both laws on an estimator near the
passive resonances of modes 2-5 (plant.modes.passive_resonance_hz: the plant's own modes with the
adaptive screw's pairs sliding at F_min, as tests/test_observer.py) and two excitation
amplitudes, 1 s each; NRMSE of v_rel and u_rel against the plant's band-limited truth, the RT1 amplitude
error, the |v_rel|-weighted sign error rate of v_rel and (Lyapunov law) the rms error of its command
F* from the estimate against F* from the truth (``frictionrt.observer.accuracy``), and the
first-harmonic acceleration at 0.45 m next to the oracle's and passive's (the last column: the
estimator's peak reduction against the oracle's, 20 log10(acc / acc oracle) [dB]).
With ``--report report.json`` (``frictionrt reproduce``) each mode and amplitude is run at the
passive step-sine peak that reproduction measured instead, where the claims' peaks are; with
``--at-peaks`` at the full reproduction's peaks that ``benchmarks.observer_error_sources.PEAKS_HZ``
holds (5, 10 and 20 N). ``--estimators KIND:SCALE ...`` runs each estimator kind (observer,
amplitude) with its model's normal springs at SCALE (``observer.spring_scale``) in every cell,
against one oracle and one passive run.

    python benchmarks/observer_accuracy.py [--duration S] [--jobs 2] [--amps 5 10 20] [--report REPORT.json]
    python -m benchmarks.observer_accuracy --at-peaks --jobs 1 --estimators observer:1 observer:0.1 amplitude:0.1 \
        [--json OUT.json]
"""
import argparse
import itertools
import math
import json
import sys
from multiprocessing import Pool
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

from frictionrt.rt.common.config import load, with_sets  # noqa: E402
from frictionrt.plant.modes import passive_resonance_hz  # noqa: E402
from frictionrt.rt.loop import Designs, build_loop, run, summary  # noqa: E402

MODES_HZ = {m: passive_resonance_hz(load(), m) for m in (2, 3, 4, 5)}
AMPS_N = (5.0, 10.0, 20.0)
KEYS = ("v_rel_nrmse", "u_rel_nrmse", "u0_rel_error", "v_rel_sign_error", "fstar_rms_error_n", "fstar_mean_error_n",
        "acc045_amplitude")


def estimator_spec(text: str) -> tuple[str, float]:
    """"KIND:SCALE" (or "KIND", scale 1) as (kind, scale); argparse's error otherwise."""
    kind, _, scale = text.partition(":")
    try:
        value = float(scale) if scale else 1.0
    except ValueError:
        value = float("nan")
    if kind not in ("observer", "amplitude") or not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"{text!r}: give KIND:SCALE, KIND observer or amplitude, SCALE in (0, 1]")
    return kind, value


def one(case) -> dict:
    """One cell: the oracle and passive runs, then each estimator (kind, scale) of the case."""
    law, mode, amp, duration, f, estimators = case
    cfg = load()
    designs = Designs()
    ora = summary(run(build_loop(cfg, law, "oracle", designs=designs), f, amp, duration))
    pas = summary(run(build_loop(cfg, "passive", "oracle", designs=designs), f, amp, duration))
    row = {"law": law, "mode": mode, "freq_hz": f, "amp_n": amp, "duration_s": duration,
           "acc_oracle": ora["acc045_amplitude"], "acc_passive": pas["acc045_amplitude"], "estimators": {}}
    for kind, scale in estimators:
        c = with_sets(cfg, [f"observer.spring_scale={scale!r}"])
        s = summary(run(build_loop(c, law, kind, designs=designs), f, amp, duration))
        row["estimators"][f"{kind}:{scale:g}"] = {k: s.get(k, float("nan")) for k in KEYS}
    return row


def format_rows(r: dict) -> list[str]:
    out = []
    for name, e in r["estimators"].items():
        acc = e["acc045_amplitude"]
        out.append(f"| {r['law']} | {r['mode']} | {r['freq_hz']:g} | {r['amp_n']:g} | {name} | {e['v_rel_nrmse']:.3f} "
                   f"| {e['u_rel_nrmse']:.3f} | {100 * e['u0_rel_error']:+.1f} % | {e['v_rel_sign_error']:.3f} | "
                   f"{e['fstar_rms_error_n']:.1f} | {acc:.2f} | {r['acc_oracle']:.2f} | {r['acc_passive']:.2f} | "
                   f"{20 * math.log10(acc / r['acc_oracle']):+.2f} |")
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration", type=float, default=1.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--amps", type=float, nargs="+", default=list(AMPS_N), help="excitation amplitudes [N]")
    ap.add_argument("--modes", type=int, nargs="+", default=list(MODES_HZ), choices=list(MODES_HZ))
    ap.add_argument("--laws", nargs="+", default=["hysteresis", "lyapunov"], choices=["hysteresis", "lyapunov"])
    where = ap.add_mutually_exclusive_group()
    where.add_argument("--report", type=Path, help="run at the passive peaks of this frictionrt reproduce report.json")
    where.add_argument("--at-peaks", action="store_true",
                       help="run at the full reproduction's passive peaks (benchmarks.observer_error_sources.PEAKS_HZ)")
    ap.add_argument("--estimators", type=estimator_spec, nargs="+", default=[("observer", 1.0)], metavar="KIND:SCALE",
                    help="estimator kinds (observer, amplitude), each with its model's normal springs at SCALE "
                         "(observer.spring_scale; default observer:1)")
    ap.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    args = ap.parse_args()
    if not args.duration > 0:
        ap.error(f"--duration {args.duration}: must be > 0 s")
    if args.at_peaks:
        from benchmarks.observer_error_sources import PEAKS_HZ
        missing = [(m, a) for m, a in itertools.product(args.modes, args.amps) if (m, a) not in PEAKS_HZ]
        if missing:
            ap.error(f"--at-peaks: no peak for mode {missing[0][0]} at {missing[0][1]:g} N; amplitudes 5, 10, 20")
        freq = lambda m, a: PEAKS_HZ[(m, a)]  # noqa: E731
    elif args.report:
        passive = json.loads(args.report.read_text())["peaks"]["passive"]
        freq = lambda m, a: passive[str(m)][f"{a:g}"]["f_hz"]  # noqa: E731
    else:
        freq = lambda m, a: MODES_HZ[m]  # noqa: E731
    cases = [(law, m, a, args.duration, freq(m, a), args.estimators)
             for law, m, a in itertools.product(args.laws, args.modes, args.amps)]
    print("| law | mode | f [Hz] | F [N] | estimator:scale | NRMSE v_rel | NRMSE u_rel | u0 error | sign error v_rel "
          "| F* error rms [N] | acc estimator | acc oracle | acc passive | estimator - oracle [dB] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    rows = []
    with Pool(args.jobs) as pool:
        for r in pool.imap(one, cases):
            rows.append(r)
            print("\n".join(format_rows(r)), flush=True)
            if args.json:
                args.json.write_text(json.dumps(rows, indent=1))
