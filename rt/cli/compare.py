"""``frictionrt compare``: the three laws at one excitation (rt.experiments.compare): table and plot."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from frictionrt.rt.cli.common import (add_controller, add_deprecated, add_force, add_out, c_exports, controller_for, fail,
                           refuse_existing)


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``compare`` (parents: frictionrt's --config/--set parser)."""
    q = sub.add_parser("compare", parents=parents, help="the three laws at one excitation: table and plot",
                       description="Run passive, hysteresis-optimal and Lyapunov with the same sine excitation "
                                   "(--amp [N] at --freq [Hz] or at the passive resonance of --mode, --duration [s]); "
                                   "print the acceleration amplitude at "
                                   "x = 0.45 m [m/s^2], its reduction against passive [%], mean F_N1 [N] and "
                                   "actuator energy [J]; optionally plot displacement and F_N1 (PNG).")
    fm = q.add_mutually_exclusive_group()
    fm.add_argument("--freq", type=float, metavar="HZ", help="excitation frequency [Hz]")
    fm.add_argument("--mode", type=int, metavar="M", default=3,
                    help="excite at the passive resonance of mode M at --amp, found by a short passive step-sine "
                         "as reproduce --quick finds its peaks (~1-2 s; compare.passive_peak_hz)")
    q.add_argument("--amp", type=float, default=5.0, metavar="N", help="force amplitude [N]")
    q.add_argument("--duration", type=float, default=1.0, metavar="S", help="simulated time per law [s]")
    q.add_argument("--estimator", choices=["observer", "oracle"], default="observer",
                   help="estimate of u_rel, v_rel for the laws: observer (default, the paper's): the Kalman-designed nonlinear observer on the tip accelerometer and the force cell (docs/observer.md); oracle: the plant's own band-limited u_rel, v_rel (the upper bound)")
    add_out(q, "FILE.png", "the file to write the time histories to (PNG)", dest="plot")
    add_deprecated(q, "--plot", "-o/--out", dest="plot")
    add_force(q)
    add_controller(q, many=True)
    q.add_argument("--json", action="store_true", help="the table as JSON")
    return q


def cmd_compare(cfg, args) -> int:
    from tqdm import tqdm

    from frictionrt.rt.common.config import LAWS
    from frictionrt.rt.experiments.compare import compare, plot, table
    from frictionrt.rt.loop import Designs, build_loop, check_run_input
    if args.plot:
        out = Path(args.plot)
        if out.suffix.lower() != ".png" or not out.parent.exists():
            return fail(f"-o {out}: give a .png file in an existing folder")
        if msg := refuse_existing([out], args.force, "-o"):
            return fail(msg)
    if args.freq is None and not 1 <= args.mode <= 9:
        return fail(f"--mode {args.mode}: give a bending mode 1..9")
    if not args.amp > 0:   # the table is relative to the passive response, which 0 N leaves at 0
        return fail(f"--amp {args.amp:g} N: compare needs a finite force > 0 N, e.g. --amp 5")
    try:
        exports = c_exports(args.controller, [(law, args.estimator) for law in LAWS])
        designs = Designs()   # the plant and force-tracking designs, made once for the three laws
        passive = build_loop(cfg, "passive", args.estimator, designs=designs)
        if args.freq is None:
            from frictionrt.rt.experiments.compare import passive_peak_hz
            check_run_input(passive, 1.0, args.amp, args.duration)  # amplitude and duration before the search
            with tqdm(unit="point", disable=args.json, desc=f"passive peak of mode {args.mode}") as bar:
                args.freq = round(passive_peak_hz(passive, args.mode, args.amp, progress=bar.update), 2)
        n = check_run_input(passive, args.freq, args.amp, args.duration)
        with tqdm(total=3 * n, unit="tick", unit_scale=True, disable=args.json, desc="compare") as bar:
            runs = compare(cfg, args.freq, args.amp, args.duration, args.estimator, progress=bar.update,
                           controller_of=lambda loop: controller_for(exports, loop, cfg.rt.seed), designs=designs)
    except ValueError as exc:
        return fail(str(exc))
    rows = [r | {"controller": f"c:{exports[r['law'], args.estimator]}" if (r["law"], args.estimator) in exports
                 else "numba"}
            for r in table(runs)]
    if args.plot:
        tmp = out.with_suffix(".tmp.png")
        plot(runs, str(tmp))
        tmp.replace(out)
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{args.amp:g} N at {args.freq:g} Hz, {args.duration:g} s per law, estimator {args.estimator}")
    if exports:
        print("controller: " + ", ".join(f"{r['law']} {r['controller']}" for r in rows))
    print(f"{'law':>11} {'acc 0.45 m [m/s^2]':>19} {'vs passive':>11} {'mean F_N1 [N]':>14} {'energy [J]':>11}")
    for r in rows:
        print(f"{r['law']:>11} {r['acc045_amplitude']:>19.4f} {-r['reduction_pct']:>+10.1f}% "
              f"{r['fn1_mean_n']:>14.1f} {r['actuator_energy_j']:>11.3g}")
    if args.plot:
        print(f"plot: {args.plot}")
    return 0

