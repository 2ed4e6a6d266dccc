"""``frictionrt reproduce``: the paper's figures and claims C1..C6 in one command (rt.experiments.reproduce).

``add_parser(subparsers, parents)`` registers the subcommand, ``cmd_reproduce(cfg, args)`` runs it
and returns the exit code (0 done, 2 bad input with one line on stderr).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from frictionrt.rt.common.config import Config
from frictionrt.rt.cli.common import add_estimator, add_force, add_out, fail, refuse_existing

DESCRIPTION = """Reproduce Becker & Gaul's experiments (SPEC section 6) and decide their claims C1..C6 on the
numbers measured: an impulse test at F_N1 = 100 N (identified modal damping), amplitude-controlled
step-sine FRFs [(m/s^2)/N] around the resonances for passive (F_N1 = F_min), hysteresis-optimal and
Lyapunov control at several excitation force amplitudes [N] (the laws on the paper's observer, and on
the oracle beside it as the upper bound), and the passive law at several constant
F_N1 [N] (the best constant clamping force: the fair baseline). Writes into --out: fig5.png (impulse
FRF), fig7.png (hysteresis vs passive), fig8.png (Lyapunov vs passive), report.md (claims table,
peak change [dB] (negative: lower than passive), best constant F_N1, actuator energy [J]) and report.json; all files appear at
once when the run has finished. Full run: modes 2-5 at 5, 10, 20 N; --quick: modes 3, 4 at 5, 20 N
on a coarse grid (docs/experiments.md)."""

EXAMPLES = """examples:
  frictionrt reproduce --quick
  frictionrt reproduce --out logs/reproduce_full --jobs 2
  frictionrt reproduce --quick --json --estimator observer   # the observer alone
  frictionrt reproduce --modes 5 --amps 5,10 --out logs/reproduce_mode5   # the full plan on mode 5 only
  frictionrt reproduce --dask tcp://10.0.0.5:8786"""


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    """Register ``reproduce`` (parents: frictionrt's --config/--set parser)."""
    p = subparsers.add_parser("reproduce", parents=parents or [], help="the paper's figures and claims C1..C6",
                              description=DESCRIPTION, epilog=EXAMPLES)
    p.add_argument("--quick", action="store_true",
                   help="modes 3 and 4, amplitudes 5 and 20 N, 9 points per mode, 2 refinement rounds, constant "
                        "F_N1 40, 150, 600 N (~20-40 s on 2 cores); default: modes 2-5, 5, 10, 20 N, 11 points, "
                        "4 rounds, F_N1 40, 80, 160, 320, 600 N")
    add_out(p, "DIR", "a folder it creates for fig5.png, fig7.png, fig8.png, report.md, report.json (default: "
                      "logs/reproduce); an existing one is refused, or with --force replaced as a whole",
            default="logs/reproduce")
    add_force(p, "an existing folder as a whole")
    add_estimator(p, both=True)
    p.add_argument("--modes", metavar="M1,M2", help="these bending modes of the plan only, e.g. 5 (of 2-5)")
    p.add_argument("--amps", metavar="A1,A2", help="these excitation amplitudes [N] instead of the plan's, at least two")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="local worker processes (default: the number of cores)")
    p.add_argument("--dask", metavar="tcp://HOST:PORT",
                   help="run the step-sine sweeps on this dask scheduler's workers instead (frictionrt installed there)")
    p.add_argument("--error-estimate", choices=["auto", "run", "none"], default="auto",
                   help="how far the plant's discretisation moves each claim's margin: C2 from the impulse test on "
                        "the refined plant, C3-C6 by Richardson from this run, the same plan with the contact "
                        "pitch and elements x2 and with the substeps x2 (order 1 each); auto (default): the margins "
                        "stored for this configuration and plan, else those runs (about three times as long); run: "
                        "always those runs; none: no "
                        "estimate, each verdict from its margin's sign")
    p.add_argument("--json", action="store_true", help="print report.json's content as one JSON object (no progress)")
    return p


def _check_out(out: Path) -> str | None:
    """None if the report can be written to out (its parent folders created, a probe file written
    and removed there), else the problem."""
    import tempfile
    if out.exists() and not out.is_dir():
        return f"--out {out}: exists and is not a folder; give a folder"
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out.parent):
            pass
    except OSError as exc:
        return f"--out {out}: cannot write in {out.parent} ({exc.strerror or exc}); give a folder you can write to"
    return None


def cmd_reproduce(cfg: Config, args) -> int:
    """Run ``frictionrt reproduce``: validate, measure, evaluate, write (rt.experiments.reproduce_report)."""
    from frictionrt.jobs import reproduce
    from frictionrt.rt.common.config import ESTIMATORS
    from frictionrt.rt.experiments.branches import sweeps_line
    from frictionrt.rt.experiments.reproduce_report import CLAIM_TEXT
    if args.jobs is not None and args.jobs < 1:
        return fail(f"--jobs {args.jobs}: must be >= 1 (local worker processes)")
    out = Path(args.out)
    problem = _check_out(out) or refuse_existing([out], args.force)
    if problem:
        return fail(problem)
    try:
        modes = [int(m) for m in args.modes.split(",")] if args.modes else None
        amps = [float(a) for a in args.amps.split(",")] if args.amps else None
    except ValueError:
        return fail(f"--modes {args.modes} / --amps {args.amps}: give comma-separated numbers, e.g. --modes 5 --amps 5,10")
    say = (lambda text: None) if args.json else (lambda text: print(f"reproduce: {text}", file=sys.stderr))
    try:
        estimators = ESTIMATORS if args.estimator == "both" else (args.estimator,)
        res = reproduce(cfg, quick=args.quick, estimators=estimators, modes=modes, amps_n=amps, out=out, force=True,
                        jobs=args.jobs, dask=args.dask, progress=not args.json, stage=say,
                        error_estimate=args.error_estimate)
    except ConnectionError as exc:
        return fail(f"--dask {args.dask}: " + " ".join(str(exc).split()))
    except OSError as exc:
        return fail(f"--out {out}: cannot write ({exc.strerror or exc}); give a folder you can write to")
    except ValueError as exc:
        return fail(str(exc))
    report = res.to_dict()
    if args.json:
        print(json.dumps(report))
        return 0
    by_est = report["by_estimator"]
    first = next(iter(by_est))
    print(f"{'claim':>5} " + " ".join(f"{e:>9}" for e in by_est) + f"  {'margin (' + first + ')':>20} "
          f"{'discretisation':>14}  statement")
    for c in report["claims"]:
        x = by_est[first]["claims"][c]
        m, shift, unit = x.get("margin"), x.get("refined_shift"), x.get("margin_unit") or ""
        margin = "model input" if x.get("margin_unit") is None else ("-" if m is None else f"{m:+.3g} {unit}")
        print(f"{c:>5} " + " ".join(f"{v['claims'][c].get('verdict', 'yes' if v['claims'][c]['holds'] else 'NO'):>9}"
                                    for v in by_est.values())
              + f"  {margin:>20} {'-' if shift is None else f'{shift:+.3g}':>14}  {CLAIM_TEXT[c]}")
    for e, v in by_est.items():
        print(f"peak change [dB] (negative: lower than passive), {e} (law: mode: amplitude): "
              f"{json.dumps(_rounded(v['peak_change_db']))}")
    print(f"wall time [s]: impulse {report['timing_s']['impulse']:.1f}, step-sine {report['timing_s']['step_sine']:.1f}; "
          + sweeps_line(report["timing_s"]["sweeps"]))
    print(f"report: {out / 'report.md'}; figures: {out / 'fig5.png'}, {out / 'fig7.png'}, {out / 'fig8.png'}")
    return 0


def _rounded(tree, digits: int = 2):
    """A nested dict of dB values rounded for people (--json keeps full precision)."""
    if isinstance(tree, dict):
        return {k: _rounded(v, digits) for k, v in tree.items()}
    return None if tree is None else round(float(tree), digits)
