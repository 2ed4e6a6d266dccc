"""``frictionrt diagnose``: the discrepancy workflow (rt.discrepancy.diagnose) on a measurement campaign; with
--out a report folder (rt.discrepancy.diagnose.report)."""
from __future__ import annotations

import argparse
import json
import sys
import time

import shtab

from frictionrt.rt.cli.common import add_force, add_out, fail
from frictionrt.rt.common.files import write_folder

INTERRUPTED = 130       # exit status after Ctrl-C (128 + SIGINT), the fits done so far kept
DESCRIPTION = """Finds where the model and a campaign's measurements disagree and names the missing effect:
calibrates the nominal model (--config/--set) on the campaign (E, mu, k_t, modal damping, ...),
fits each effect of the library with it, ranks them by BIC and names the best only where it beats
calibration alone clearly (else "no missing effect found"); reports the gap before and after. A
folder of FRF files is fitted with the linear stuck-contact model; --calibrate-on LEVELS fits the
joints' harmonic balance on some levels and predicts the others. Progress bars on stderr; Ctrl-C
keeps the fits done so far (exit 130). Method, run times and the report: docs/discrepancy.md."""

EXAMPLES = """examples:
  frictionrt diagnose logs/campaign_acc
  frictionrt diagnose logs/campaign_acc --json --out logs/diag_acc   # report.md, model.toml, PNGs, diagnosis.rrd
  frictionrt diagnose logs/campaign_ss --dask tcp://10.0.0.5:8786   # fits and model step-sines on a cluster
  frictionrt --config logs/diag_acc/model.toml impulse     # the updated model in other commands
  frictionrt --config configs/lap_joint.toml diagnose lab/frf_tests --out lab/diag   # FRF files, any structure
  frictionrt diagnose logs/frf_levels --calibrate-on 0.5,1 --out logs/diag_levels   # predict the higher levels"""


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    p = subparsers.add_parser("diagnose", parents=parents or [], help="find, name and add the missing effect "
                              "of a measurement campaign", description=DESCRIPTION, epilog=EXAMPLES)
    p.add_argument("folder", metavar="DIR", help="campaign folder of *.mcap measurements (impulse and actuator "
                   "tests, e.g. from frictionrt rig), or a folder of FRF files with sidecars (frictionrt rig "
                   "--frf-files)").complete = shtab.DIRECTORY
    p.add_argument("--json", action="store_true", help="print one JSON object (named_effect, ranking, gap_before, "
                   "gap_after, fitted_parameters, ...)")
    add_out(p, "REPORT_DIR", "a folder it creates for report.md, diagnose.json, model.toml (the updated model), "
                             "FRF/actuator overlay PNGs and diagnosis.rrd; an existing one is refused, or with "
                             "--force replaced as a whole")
    add_force(p, "an existing folder as a whole")
    p.add_argument("--jobs", type=int, metavar="N", help="processes for the candidates' fits and the model "
                   "step-sines (default: the number of cores; 1: in this process); the result is the same for any N")
    p.add_argument("--dask", metavar="tcp://HOST:PORT",
                   help="run the candidates' fits and the model step-sines on this dask scheduler's workers instead "
                        "(frictionrt installed there; the same result); a folder of FRF files is diagnosed here")
    p.add_argument("--calibrate-on", metavar="A,B,..", help="FRF files at several levels: calibrate on the files at "
                   "these force amplitudes [N] (sidecar amplitude_n) and predict the others, linear model against "
                   "the harmonic balance of the joints (rt/discrepancy/diagnose/levels.py)")
    p.add_argument("--harmonic-method", choices=("df", "aft"), default="df",
                   help="with --calibrate-on: the harmonic balance's method. df: describing functions, the normal "
                        "contact linear (fast; exact while the joint stays closed); aft: the pair law over the "
                        "period, for joints whose contact opens (about 4x the cost; random tests take df only)")
    return p


def cmd_diagnose(cfg, args) -> int:
    from pathlib import Path
    if args.out and Path(args.out).exists() and not args.force:
        return fail(f"--out {args.out}: exists; pass --force to replace it as a whole, or give a new folder")
    if args.jobs is not None and args.jobs < 1:
        return fail(f"diagnose --jobs {args.jobs}: give 1 or more processes")
    say = None if args.json else lambda m: print(f"  {m}", file=sys.stderr)
    t0 = time.perf_counter()
    code = _levels(cfg, args, say) if args.calibrate_on is not None else _campaign_or_frf(cfg, args, say)
    if code in (0, INTERRUPTED):
        print(f"diagnose: {time.perf_counter() - t0:.1f} s wall", file=sys.stderr)
    return code


def _json(res: dict) -> str:
    """A levels or interrupted result as --json prints it: without its "_" keys (configuration, plots)."""
    return json.dumps({k: v for k, v in res.items() if not k.startswith("_")})


def _interrupted(part: dict, args) -> int:
    """Ctrl-C: the fits done so far (rt.discrepancy.diagnose.watch.partial_result) printed and, with --out, in
    its folder (written beside and renamed); a line on stderr says where; exit status INTERRUPTED."""
    from frictionrt.rt.discrepancy.diagnose.watch import partial_summary, write_partial_report
    if args.out and part["fits"]:
        write_folder(args.out, args.force, lambda: write_partial_report(part, args.out))
    print(_json(part) if args.json else partial_summary(part))
    kept = (f"the {len(part['fits'])} fits done so far are in {args.out}" if args.out else "printed above"
            ) if part["fits"] else "before the first fit ended: nothing to keep"
    print(f"diagnose: interrupted; {kept}", file=sys.stderr)
    return INTERRUPTED


def _campaign_or_frf(cfg, args, say) -> int:
    """``diagnose`` of a campaign (rt.discrepancy.diagnose.campaign) or of FRF files (.frf)."""
    from frictionrt.jobs import diagnose
    from frictionrt.rt.discrepancy.diagnose.watch import Interrupted
    try:
        res = diagnose(args.folder, cfg, out=args.out, force=args.force, jobs=args.jobs, dask=args.dask, progress=say,
                       bars=True)
    except ConnectionError as exc:
        return fail(f"diagnose --dask {args.dask}: " + " ".join(str(exc).split()))
    except ValueError as exc:
        return fail(f"diagnose: {exc}")
    except Interrupted as stop:   # Ctrl-C: keep the fits done so far
        return _interrupted(stop.partial, args)
    print(res.to_json() if args.json else str(res))
    return 0


def _levels(cfg, args, say) -> int:
    """``diagnose --calibrate-on``: rt.discrepancy.diagnose.levels."""
    from frictionrt.rt.cli.common import parse_list
    from frictionrt.rt.discrepancy.diagnose import is_frf_folder
    from frictionrt.rt.discrepancy.diagnose.levels import diagnose_levels
    from frictionrt.rt.discrepancy.diagnose.levels_report import summary, write_levels_report
    from frictionrt.rt.discrepancy.diagnose.watch import Interrupted
    try:
        levels = parse_list(args.calibrate_on, float, "diagnose --calibrate-on", "0.5,1")
    except ValueError as exc:
        return fail(str(exc))
    if not is_frf_folder(args.folder):
        return fail(f"diagnose --calibrate-on: {args.folder} is not a folder of FRF files (rig --frf-files --levels "
                    "writes one)")
    try:
        res = diagnose_levels(args.folder, levels, cfg, progress=say, method=args.harmonic_method, bars=True)
    except ValueError as exc:
        return fail(f"diagnose: {exc}")
    except Interrupted as stop:   # Ctrl-C: keep the fits done so far
        return _interrupted(stop.partial, args)
    if args.out:
        write_folder(args.out, args.force, lambda: write_levels_report(res, args.out))
    print(_json(res) if args.json else summary(res))
    return 0
