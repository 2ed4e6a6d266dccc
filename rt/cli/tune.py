"""``frictionrt tune``: grid search of a law's gains (rt.experiments.tune) with a table, a Pareto plot and the
best configuration as TOML.

``add_parser(subparsers, parents)`` registers the subcommand, ``cmd_tune(cfg, args)`` runs it and
returns the exit code (0 done, 2 bad input with one line on stderr).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from frictionrt.rt.common.config import Config, ConfigError
from frictionrt.rt.cli.structure import add_structure
from frictionrt.rt.cli.common import CommaList, add_estimator, add_force, add_out, fail, parse_list, refuse_existing

DESCRIPTION = """Tune a semi-active law: every combination of the --grid values is a candidate configuration;
each runs step-sine sweeps around --modes at each --amps [N] force amplitude, and is scored by
  1. the mean peak change against the passive law (constant F_N1 = tracking.F_passive_N) [dB],
     20 log10(peak_law / peak_passive): negative = the law's peak is lower, and
  2. the mean actuator power during the measurements [W].
The candidates that no other beats on both are the Pareto front. The best (most negative peak change, within
--max-power if given) is written as a full configuration that every command takes with --config.

Writes into --out DIR: table.csv and table.md (one row per candidate), pareto.png, best.toml, tune.json.
Default grids: hysteresis K_f x T1 (5 x 3), lyapunov eps (5). Any numeric configuration key can be
swept, e.g. the force-tracking loop (tracking.pid_bandwidth_hz, tracking.pid_phase_margin_deg,
tracking.setpoint_filter_hz) or the observer's noise covariances (observer.exc_noise_N,
observer.fric_noise_N, observer.meas_noise_m_s). The laws run on the paper's observer (the
default) or, with --estimator oracle, on the plant's own u_rel, v_rel (the upper bound)."""

EXAMPLES = """examples:
  frictionrt tune --law hysteresis --modes 3,4 --amps 5,20
  frictionrt tune --law lyapunov --grid tracking.eps_m_s=0.003,0.01,0.03 --grid tracking.pid_bandwidth_hz=150,300
  frictionrt tune --law hysteresis --grid observer.fric_noise_N=100,300,1000 --out logs/tune_obs
  frictionrt tune --law lyapunov --estimator oracle --out logs/tune_oracle
  frictionrt --config logs/tune_hysteresis/best.toml frf --law hysteresis --amps 5 --around-modes 3"""


def add_parser(subparsers, parents) -> argparse.ArgumentParser:
    """Register ``tune`` on an argparse subparsers object (parents: frictionrt's --config/--set)."""
    p = subparsers.add_parser("tune", parents=parents, help="grid search of a law's gains: table, Pareto plot, best TOML",
                              description=DESCRIPTION, epilog=EXAMPLES)
    p.add_argument("--law", choices=["hysteresis", "lyapunov"], required=True, help="the law to tune")
    p.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2,...",
                   help="a configuration key and its values (SI units, as in frictionrt config --show); "
                        "repeatable, the candidates are all combinations (default: the law's own gains)")
    p.add_argument("--modes", default="3,4", metavar="M1,M2,...",
                   help="bending modes whose peaks are scored (mode 1 is at 9.8 Hz)")
    p.add_argument("--amps", "--amp", action=CommaList, kind=float, default=[5.0], metavar="N1,N2",
                   help="excitation force amplitude(s) [N], held on the measured force, comma-separated")
    p.add_argument("--points", type=int, default=9, metavar="N",
                   help="step-sine frequencies per mode over +/- --half-width")
    p.add_argument("--half-width", type=float, default=0.15, metavar="REL",
                   help="half width of each mode's band, relative to its centre")
    add_estimator(p)
    p.add_argument("--max-power", type=float, default=None, metavar="W",
                   help="pick the best candidate among those using at most this mean actuator power [W]")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="local worker processes (default: the number of cores)")
    p.add_argument("--dask", metavar="tcp://HOST:PORT", help="run the sweeps on this dask scheduler's workers")
    add_out(p, "DIR", "a folder it creates for table.csv, table.md, pareto.png, best.toml, tune.json (default: "
                      "logs/tune_LAW); an existing one is refused, or with --force its tune files are replaced")
    add_force(p, "the tune files of an existing folder")
    p.add_argument("--json", action="store_true", help="print the result as one JSON object (no progress bar)")
    add_structure(p)
    return p


def cmd_tune(cfg: Config, args) -> int:
    from frictionrt.jobs import tune
    from frictionrt.rt.experiments.branches import sweeps_line
    from frictionrt.rt.experiments.tune import markdown_table, parse_grid
    out = Path(args.out or f"logs/tune_{args.law}")
    if out.exists() and not out.is_dir():
        return fail(f"--out {out}: exists and is not a folder")
    if msg := refuse_existing([out], args.force):
        return fail(msg)
    parent = out if out.exists() else out.parent
    while not parent.exists():
        parent = parent.parent
    if not os.access(parent, os.W_OK):
        return fail(f"--out {out}: folder {parent} is not writable")
    if args.jobs is not None and args.jobs < 1:
        return fail(f"--jobs {args.jobs}: must be >= 1")
    try:
        grid = parse_grid(args.grid) if args.grid else None
        modes = parse_list(args.modes, int, "--modes", "3,4")
        res = tune(cfg, law=args.law, grid=grid, modes=modes, amps_n=args.amps, points=args.points,
                   half_width=args.half_width, estimator=args.estimator, max_power_w=args.max_power, jobs=args.jobs,
                   dask=args.dask, out=out, force=True, progress=not args.json, structure=args.structure,
                   clusters=args.clusters, clustering=args.clustering)
    except ConfigError as exc:
        return fail(f"--grid: {exc}")
    except ConnectionError as exc:
        return fail(f"--dask {args.dask}: " + " ".join(str(exc).split()))
    except ValueError as exc:
        return fail(str(exc))
    for w in res.warnings or []:
        print(f"frictionrt tune: warning: {w}", file=sys.stderr)
    doc = res.to_dict()
    doc["out"] = str(out)
    if args.json:
        print(json.dumps(doc))
        return 0
    print(f"tune {res.law}: {len(res.values)} candidates, modes {list(res.modes)}, amplitudes {list(res.amps_n)} N; "
          f"passive peaks [(m/s^2)/N]: {', '.join(f'{v:.3g}' for v in res.passive_peak.ravel())}")
    print(markdown_table(res.rows(), res.keys), end="")
    if res.best < 0:
        print("no candidate qualifies (all refused, or none within --max-power); best.toml not written")
    else:
        print(f"best: {out / 'best.toml'}")
        for key in res.best_on_edge():
            print(f"note: the best {key} is at the end of its grid; the optimum may lie beyond it (extend --grid {key})")
    print(sweeps_line(res.timing))
    print(f"files: {out}/table.csv, table.md, pareto.png, tune.json")
    return 0
