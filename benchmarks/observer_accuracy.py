"""Observer accuracy table (docs/observer.md section 6): both laws on the observer near the
passive resonances of modes 2-5 (plant.modes.passive_resonance_hz: the plant's own modes with the
adaptive screw's pairs sliding at F_min, as tests/test_observer.py) and two excitation
amplitudes, 1 s each; NRMSE of v_rel and u_rel against the plant's band-limited truth, the RT1 amplitude
error, and the first-harmonic acceleration at 0.45 m next to the oracle's and passive's.
With ``--report report.json`` (``frictionrt reproduce``) each mode and amplitude is run at the
passive step-sine peak that reproduction measured instead, where the claims' peaks are.

    python benchmarks/observer_accuracy.py [--duration S] [--jobs 2] [--report REPORT.json]
"""
import argparse
import itertools
import json
import sys
from multiprocessing import Pool
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

from frictionrt.rt.common.config import load  # noqa: E402
from frictionrt.plant.modes import passive_resonance_hz  # noqa: E402
from frictionrt.rt.loop import build_loop, run, summary  # noqa: E402

MODES_HZ = {m: passive_resonance_hz(load(), m) for m in (2, 3, 4, 5)}
AMPS_N = (5.0, 10.0)


def one(case):
    law, mode, amp, duration, f = case
    obs = summary(run(build_loop(load(), law, "observer"), f, amp, duration))
    ora = summary(run(build_loop(load(), law), f, amp, duration))
    pas = summary(run(build_loop(load(), "passive"), f, amp, duration))
    return (law, mode, f, amp, obs["v_rel_nrmse"], obs["u_rel_nrmse"], obs["u0_rel_error"],
            obs["acc045_amplitude"], ora["acc045_amplitude"], pas["acc045_amplitude"])


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration", type=float, default=1.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--report", type=Path, help="run at the passive peaks of this frictionrt reproduce report.json")
    args = ap.parse_args()
    passive = json.loads(args.report.read_text())["peaks"]["passive"] if args.report else None
    cases = [(law, m, a, args.duration, MODES_HZ[m] if passive is None else passive[str(m)][f"{a:g}"]["f_hz"])
             for law, m, a in itertools.product(("hysteresis", "lyapunov"), MODES_HZ, AMPS_N)]
    print("| law | mode | f [Hz] | F [N] | NRMSE v_rel | NRMSE u_rel | u0 error | acc observer | acc oracle | acc passive |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    with Pool(args.jobs) as pool:
        for r in pool.imap(one, cases):
            print(f"| {r[0]} | {r[1]} | {r[2]:g} | {r[3]:g} | {r[4]:.3f} | {r[5]:.3f} | {100 * r[6]:+.1f} % | "
                  f"{r[7]:.2f} | {r[8]:.2f} | {r[9]:.2f} |", flush=True)
