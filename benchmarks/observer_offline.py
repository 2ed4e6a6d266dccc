"""Where the real-time observer stands against an unconstrained estimator of the same model
(issue 4): closed-loop runs with the observer, then filterpy's UKF and its RTS smoother
(``frictionrt.observer.offline``) on each run's logged tip velocity and force-cell reading.

    python benchmarks/observer_offline.py [--freqs 196 378] [--amp 5] [--duration 0.5]
                                          [--laws hysteresis lyapunov] [--json]

NRMSE of v_rel and u_rel against the band-limited plant truth over the last 20 % of each run,
for the real-time observer (rt), the UKF (causal) and the UKF + RTS smoother (non-causal); first
row by row as ``frictionrt simulate`` reports it, then with the truth at the estimates' instant,
then the error of the first harmonic alone (``frictionrt.observer.offline.compare_on_run``). Slow: the UKF
is plain Python (0.4..1 ms per tick, about as much again for the smoother): 10..20 s per 0.5 s
run, plus the run itself.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

# run as a script, this folder comes first on sys.path, and benchmarks/plant.py would shadow the
# plant package
_HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) != _HERE]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--freqs", type=float, nargs="+", default=[196.0, 378.0],
                    help="excitation frequencies [Hz] (default: the mode-3 and mode-4 resonances)")
    ap.add_argument("--amp", type=float, default=5.0, help="excitation amplitude [N]")
    ap.add_argument("--duration", type=float, default=0.5, help="run length [s]")
    ap.add_argument("--laws", nargs="+", default=["hysteresis", "lyapunov"])
    ap.add_argument("--json", action="store_true", help="print the rows as JSON")
    a = ap.parse_args(argv)
    from frictionrt.observer.kalman import design_observer  # after the sys.path fix above
    from frictionrt.observer.offline import compare_on_run
    from frictionrt.rt.common.config import load
    from frictionrt.rt.loop import build_loop, run

    cfg = load()
    design = design_observer(cfg)
    rows = []
    for law in a.laws:
        loop = build_loop(cfg, law, "observer")
        for f in a.freqs:
            t0 = time.perf_counter()
            r = run(loop, f, a.amp, a.duration)
            t_run = time.perf_counter() - t0
            c = compare_on_run(r, design=design)
            rows.append({"law": law, "freq_hz": f, "amp_n": a.amp, "duration_s": a.duration, **c,
                         "run_wall_s": t_run})
            if not a.json:
                print(f"  {law} {f:g} Hz done ({t_run:.1f} s run, UKF {c['ukf_us_per_step']:.0f} us/tick, "
                      f"RTS {c['rts_us_per_step']:.0f} us/tick)", file=sys.stderr)
    if a.json:
        print(json.dumps(rows, indent=1))
        return 0
    for key, title in (("_nrmse", "NRMSE, row by row (as frictionrt simulate)"),
                       ("_nrmse_aligned", "NRMSE, truth at the estimates' instant"),
                       ("_fund_error", "first-harmonic error |X_hat - X| / |X|, truth at the estimates' instant")):
        print(f"\n{title}; {a.amp:g} N, {a.duration:g} s, last 20 %")
        print(f"{'law':<11}{'f [Hz]':>7} | {'v_rel: rt':>9}{'ukf':>7}{'rts':>7} | {'u_rel: rt':>9}{'ukf':>7}{'rts':>7}"
              f" | {'UKF us/tick':>11}{'RTS us/tick':>12}")
        for r in rows:
            v, u = r["v_rel" + key], r["u_rel" + key]
            print(f"{r['law']:<11}{r['freq_hz']:>7g} | {v['rt']:>9.3f}{v['ukf']:>7.3f}{v['rts']:>7.3f} | "
                  f"{u['rt']:>9.3f}{u['ukf']:>7.3f}{u['rts']:>7.3f} | {r['ukf_us_per_step']:>11.0f}"
                  f"{r['rts_us_per_step']:>12.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
