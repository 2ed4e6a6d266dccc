"""Observer accuracy table (docs/observer.md section 6): both laws on the observer near the
passive resonances of modes 2-5 (plant.modes.passive_resonance_hz: the plant's own modes with the
adaptive screw's pairs sliding at F_min, as tests/test_observer.py) and two excitation
amplitudes, 1 s each; NRMSE of v_rel and u_rel against the plant's band-limited truth, the RT1 amplitude
error, the |v_rel|-weighted sign error rate of v_rel and (Lyapunov law) the rms error of its command
F* from the estimate against F* from the truth (``frictionrt.observer.accuracy``), and the
first-harmonic acceleration at 0.45 m next to the oracle's and passive's.
With ``--report report.json`` (``frictionrt reproduce``) each mode and amplitude is run at the
passive step-sine peak that reproduction measured instead, where the claims' peaks are.

    python benchmarks/observer_accuracy.py [--duration S] [--jobs 2] [--amps 5 10 20] [--report REPORT.json]
"""
import argparse
import itertools
import math
import json
import sys
from multiprocessing import Pool
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

from frictionrt.rt.common.config import load  # noqa: E402
from frictionrt.plant.modes import passive_resonance_hz  # noqa: E402
from frictionrt.rt.loop import build_loop, run, summary  # noqa: E402

MODES_HZ = {m: passive_resonance_hz(load(), m) for m in (2, 3, 4, 5)}
AMPS_N = (5.0, 10.0, 20.0)


def one(case):
    law, mode, amp, duration, f = case
    obs = summary(run(build_loop(load(), law, "observer"), f, amp, duration))
    ora = summary(run(build_loop(load(), law), f, amp, duration))
    pas = summary(run(build_loop(load(), "passive"), f, amp, duration))
    return (law, mode, f, amp, obs["v_rel_nrmse"], obs["u_rel_nrmse"], obs["u0_rel_error"], obs["v_rel_sign_error"],
            obs.get("fstar_rms_error_n", float("nan")),
            obs["acc045_amplitude"], ora["acc045_amplitude"], pas["acc045_amplitude"])


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration", type=float, default=1.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--amps", type=float, nargs="+", default=list(AMPS_N), help="excitation amplitudes [N]")
    ap.add_argument("--modes", type=int, nargs="+", default=list(MODES_HZ), choices=list(MODES_HZ))
    ap.add_argument("--laws", nargs="+", default=["hysteresis", "lyapunov"], choices=["hysteresis", "lyapunov"])
    ap.add_argument("--report", type=Path, help="run at the passive peaks of this frictionrt reproduce report.json")
    args = ap.parse_args()
    passive = json.loads(args.report.read_text())["peaks"]["passive"] if args.report else None
    cases = [(law, m, a, args.duration, MODES_HZ[m] if passive is None else passive[str(m)][f"{a:g}"]["f_hz"])
             for law, m, a in itertools.product(args.laws, args.modes, args.amps)]
    print("| law | mode | f [Hz] | F [N] | NRMSE v_rel | NRMSE u_rel | u0 error | sign error v_rel | F* error rms [N] "
          "| acc observer | acc oracle | acc passive | observer - oracle [dB] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    with Pool(args.jobs) as pool:
        for r in pool.imap(one, cases):
            print(f"| {r[0]} | {r[1]} | {r[2]:g} | {r[3]:g} | {r[4]:.3f} | {r[5]:.3f} | {100 * r[6]:+.1f} % | "
                  f"{r[7]:.3f} | {r[8]:.1f} | {r[9]:.2f} | {r[10]:.2f} | {r[11]:.2f} | "
                  f"{20 * math.log10(r[9] / r[10]):+.2f} |", flush=True)
