"""``frictionrt diagnose``: the discrepancy workflow (rt.discrepancy.diagnose) on a measurement campaign; with
--out a report folder (rt.discrepancy.diagnose_report)."""
from __future__ import annotations

import argparse
import json
import sys

from rt.cli.common import add_out, fail

DESCRIPTION = """Runs the nominal model (--config/--set) on the campaign's measured inputs (hammer force,
V_cmd), calibrates E, mu, k_t, modal damping and c_v, fits each implemented effect of the library
jointly with the calibration (structure: on the log-magnitude FRFs of both accelerometers at every
F_N1; actuator: on V_a, i, F_cell; with step-sine files (rig --stepsine): the shaker on the force
ratio F_amp/drive), ranks them by BIC and names the best only if it beats calibration alone by more
than 10, removes at least 25 % of its channels' residual sum of squares and is fitted away from its
nominal strength (else "no missing effect found"). The candidates' fits and the model's step-sines
run in --jobs processes, or on a dask cluster with --dask.
About 10-25 s per campaign on 2 cores (30-50 s with step-sine tests).
A folder of measured FRF files instead (*.csv/*.uff/*.unv with JSON sidecars, no *.mcap;
docs/data-format.md "FRF files") is fitted with the linear stuck-contact model of the --config
structure: E, k_t, modal damping and each structural effect on the log-magnitude FRFs (mu cannot
act there), about 10 s. Method: docs/discrepancy.md."""

EXAMPLES = """examples:
  frictionrt diagnose logs/campaign_acc
  frictionrt diagnose logs/campaign_acc --json --out logs/diag_acc   # report.md, model.toml, PNGs, diagnosis.rrd
  frictionrt diagnose logs/campaign_ss --dask tcp://10.0.0.5:8786   # fits and model step-sines on a cluster
  frictionrt --config logs/diag_acc/model.toml impulse     # the updated model in other commands
  frictionrt --config configs/lap_joint.toml diagnose lab/frf_tests --out lab/diag   # FRF files, any structure"""


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    p = subparsers.add_parser("diagnose", parents=parents or [], help="find, name and add the missing effect "
                              "of a measurement campaign", description=DESCRIPTION, epilog=EXAMPLES,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folder", metavar="DIR", help="campaign folder of *.mcap measurements (impulse and actuator "
                   "tests, e.g. from frictionrt rig), or a folder of FRF files with sidecars (frictionrt rig "
                   "--frf-files)")
    p.add_argument("--json", action="store_true", help="print one JSON object (named_effect, ranking, gap_before, "
                   "gap_after, fitted_parameters, ...)")
    add_out(p, "REPORT_DIR", "write report.md, diagnose.json, model.toml (the updated model) and FRF/actuator "
                             "overlay PNGs into this new folder (a diagnosis is never replaced: no --force)")
    p.add_argument("--jobs", type=int, metavar="N", help="processes for the candidates' fits and the model "
                   "step-sines (default: the number of cores; 1: in this process); the result is the same for any N")
    p.add_argument("--dask", metavar="tcp://HOST:PORT",
                   help="run the candidates' fits and the model step-sines on this dask scheduler's workers instead "
                        "(frictionrt installed there; the same result); a folder of FRF files is diagnosed here")
    return p


def cmd_diagnose(cfg, args) -> int:
    from rt.discrepancy.diagnose import diagnose, public, summary
    from rt.discrepancy.diagnose_frf import diagnose_frf, is_frf_folder
    from pathlib import Path
    if args.out and Path(args.out).exists():
        return fail(f"--out {args.out}: exists; a diagnosis is never replaced, give a new folder")
    if args.jobs is not None and args.jobs < 1:
        return fail(f"diagnose --jobs {args.jobs}: give 1 or more processes")
    say = None if args.json else lambda m: print(f"  {m}", file=sys.stderr)
    try:
        if is_frf_folder(args.folder):
            res = diagnose_frf(args.folder, cfg, progress=say)
        else:
            res = diagnose(args.folder, cfg, progress=say, jobs=args.jobs, dask_address=args.dask)
    except ConnectionError as exc:
        return fail(f"diagnose --dask {args.dask}: " + " ".join(str(exc).split()))
    except ValueError as exc:
        return fail(f"diagnose: {exc}")
    if args.out:
        from rt.discrepancy.diagnose_report import write_report
        write_report(res, args.out)
    print(json.dumps(public(res)) if args.json else summary(res))
    return 0
