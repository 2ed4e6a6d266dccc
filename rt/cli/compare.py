"""``frictionrt compare``: the three laws at one excitation (rt.experiments.compare): table and plot."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from frictionrt.rt.cli.structure import add_structure
from frictionrt.rt.cli.common import (add_estimator, add_controller, add_deprecated, add_force, add_out, c_exports, controller_for, fail,
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
    add_estimator(q)
    add_out(q, "FILE.png", "the file to write the time histories to (PNG)", dest="plot")
    add_deprecated(q, "--plot", "-o/--out", dest="plot")
    add_force(q)
    add_controller(q, many=True)
    q.add_argument("--json", action="store_true", help="the table as JSON")
    add_structure(q)
    return q


def cmd_compare(cfg, args) -> int:
    from frictionrt.jobs import compare
    from frictionrt.rt.common.config import LAWS
    if args.plot:
        out = Path(args.plot)
        if out.suffix.lower() != ".png" or not out.parent.exists():
            return fail(f"-o {out}: give a .png file in an existing folder")
        if msg := refuse_existing([out], args.force, "-o"):
            return fail(msg)
    try:
        exports = c_exports(args.controller, [(law, args.estimator) for law in LAWS])
        res = compare(cfg, mode=args.mode, amp_n=args.amp, duration_s=args.duration, freq_hz=args.freq,
                      estimator=args.estimator, progress=not args.json,
                      controller_of=(lambda loop: controller_for(exports, loop, cfg.rt.seed)) if exports else None,
                      structure=args.structure, clusters=args.clusters, clustering=args.clustering)
    except ValueError as exc:
        return fail(str(exc).replace("freq_hz (--freq)", "--freq").replace("mode ", "--mode ", 1)
                    .replace("amplitude ", "--amp ", 1))
    rows = [r | {"controller": f"c:{exports[r['law'], args.estimator]}" if (r["law"], args.estimator) in exports
                 else "numba"}
            for r in res["rows"]]
    if args.plot:
        tmp = out.with_suffix(".tmp.png")
        res.plot().savefig(tmp, dpi=110)
        tmp.replace(out)
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{args.amp:g} N at {res['freq_hz']:g} Hz, {args.duration:g} s per law, estimator {args.estimator}"
          + (f", imported structure {args.structure}" + (f" ({args.clusters} points)" if args.clusters else "")
             if args.structure else ""))
    if exports:
        print("controller: " + ", ".join(f"{r['law']} {r['controller']}" for r in rows))
    print(f"{'law':>11} {'acc 0.45 m [m/s^2]':>19} {'vs passive':>11} {'mean F_N1 [N]':>14} {'energy [J]':>11}")
    for r in rows:
        print(f"{r['law']:>11} {r['acc045_amplitude']:>19.4f} {r['change_pct']:>+10.1f}% "
              f"{r['fn1_mean_n']:>14.1f} {r['actuator_energy_j']:>11.3g}")
    if args.plot:
        print(f"plot: {args.plot}")
    return 0
