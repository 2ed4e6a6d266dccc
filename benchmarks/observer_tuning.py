"""Observer tuning by simulation (SPEC section 5): a law (default hysteresis) on the observer designed
with each candidate setting, at the passive step-sine peaks of modes 2-5 (``observer_error_sources.PEAKS_HZ``);
NRMSE of v_rel and u_rel against the plant's band-limited truth, the law's u0 error, the
|v_rel|-weighted sign error, the Lyapunov command's F* error and the first-harmonic acceleration at 0.45 m.

    python -m benchmarks.observer_tuning [--law hysteresis] [--amps 5 10] [--duration 0.5] [--jobs 2]
                                         [--candidate NAME=KEY=VALUE[,KEY=VALUE...] ...]

Without --candidate: the default design, the excitation's process noise x3 and x10
(observer.exc_noise_N 60, 200 N, the friction's kept at 5x: the design's stability rule), the modal
damping at the joint's 1.5 % (observer.modal_damping = 0.015), and alpha 30 s/m.
"""
from __future__ import annotations

import argparse
import itertools
from multiprocessing import Pool

from benchmarks.entry import run_main
from benchmarks.observer_error_sources import PEAKS_HZ

CANDIDATES = {
    "default": (),
    "exc_noise 60 N": ("observer.exc_noise_N=60", "observer.fric_noise_N=300"),
    "exc_noise 200 N": ("observer.exc_noise_N=200", "observer.fric_noise_N=1000"),
    "modal_damping 0.015": ("observer.modal_damping=0.015",),
    "alpha 30 s/m": ("observer.alpha_s_m=30",),
}


def one(case) -> tuple:
    name, sets, law, mode, amp, duration = case
    from frictionrt.rt.common.config import load, with_sets
    from frictionrt.rt.loop import build_loop, run, summary
    cfg = load()
    ocfg = with_sets(cfg, list(sets))
    s = summary(run(build_loop(cfg, law, "observer", observer_cfg=ocfg), PEAKS_HZ[(mode, amp)], amp, duration))
    return (name, mode, amp, s["v_rel_nrmse"], s["u_rel_nrmse"], s["u0_rel_error"], s["v_rel_sign_error"],
            s.get("fstar_rms_error_n", float("nan")), s["acc045_amplitude"])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--amps", type=float, nargs="+", default=[5.0, 10.0], choices=[5.0, 10.0, 20.0])
    ap.add_argument("--modes", type=int, nargs="+", default=[2, 3, 4, 5], choices=[2, 3, 4, 5])
    ap.add_argument("--law", default="hysteresis", choices=["hysteresis", "lyapunov"])
    ap.add_argument("--duration", type=float, default=0.5, help="simulated time per run [s]")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes")
    ap.add_argument("--candidate", action="append", default=[], metavar="NAME=KEY=VALUE[,KEY=VALUE...]",
                    help="a design to try (repeatable); default: CANDIDATES")
    a = ap.parse_args(argv)
    if not a.duration > 0:
        ap.error(f"--duration {a.duration}: must be > 0 s")
    cands = dict(CANDIDATES)
    if a.candidate:
        cands = {}
        for c in a.candidate:
            name, sep, sets = c.partition("=")
            if not sep or not sets:
                ap.error(f"--candidate {c!r}: expected NAME=KEY=VALUE[,KEY=VALUE...]")
            cands[name] = tuple(sets.split(","))
    cases = [(n, s, a.law, m, amp, a.duration) for (n, s), m, amp in itertools.product(cands.items(), a.modes, a.amps)]
    print("| design | mode | F [N] | NRMSE v_rel | NRMSE u_rel | u0 error | sign error v_rel | F* error rms [N] | acc [m/s^2] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    with Pool(a.jobs) as pool:
        for n, m, amp, nv, nu, e0, se, fe, acc in pool.imap(one, cases):
            print(f"| {n} | {m} | {amp:g} | {nv:.3f} | {nu:.3f} | {100 * e0:+.1f} % | {se:.3f} | {fe:.1f} | {acc:.2f} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    run_main(main)
