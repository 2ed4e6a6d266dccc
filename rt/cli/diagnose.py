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
DESCRIPTION = """Runs the nominal model (--config/--set) on the campaign's measured inputs (hammer force,
V_cmd), calibrates E, mu, k_t, modal damping, c_v and the dispersion (the data's time step against
the model's: 0 for the virtual rig's own data, ~1 for a lab's), fits each implemented effect of the library
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
act there), about 10 s. With --calibrate-on LEVELS (FRF files at several force amplitudes, e.g. from
rig --frf-files --levels): the linear model and the harmonic balance of the joints (plant.harmonic_frf)
are calibrated on the files at those levels only and predict the others; the report gives both
predictions' gaps around the softening mode (1-2 min); --harmonic-method aft for a joint whose contact
opens and closes (about 2 min on configs/lap_joint_al.toml). Random tests (rig --excitation random; a lab's
1,600 lines a level) are the joint linearised under its random gap, about 1 min for six levels. Every diagnosis shows its fits' progress
on stderr (with --json too): a bar over each fit's model evaluations with its best cost, and one over the
candidates' fits run in parallel. Ctrl-C stops it and keeps the fits done so far, and the best point of
the fit it stopped (printed, and in --out's folder, written beside and renamed; exit 130). Every fit
stays within what the configuration accepts (e.g. plant.interface.mu 0..2). The wall time is printed
on stderr. Method: docs/discrepancy.md."""

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
                   help="with --calibrate-on: the harmonic balance's method (plant/harmonic_frf.py). df: "
                        "describing functions with the normal contact linear, fast (0.1 s a model, 0.06 ms a line), "
                        "exact while "
                        "the joint stays closed; aft: the plant's own pair law over the period (contact opening and "
                        "closing, slip limit following the normal force), for joints that gape, e.g. a lap joint's "
                        "overlap ends (about 4x the cost; docs/discrepancy.md \"Amplitude dependence\"). Random "
                        "tests (rig --excitation random) take df only: their joint is linearised under its simulated "
                        "random gap (rt/discrepancy/diagnose/random_level.py)")
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
    from frictionrt.rt.discrepancy.diagnose import diagnose, diagnose_frf, is_frf_folder, public, summary
    from frictionrt.rt.discrepancy.diagnose.watch import Interrupted
    try:
        if is_frf_folder(args.folder):
            res = diagnose_frf(args.folder, cfg, progress=say, bars=True)
        else:
            res = diagnose(args.folder, cfg, progress=say, jobs=args.jobs, dask_address=args.dask, bars=True)
    except ConnectionError as exc:
        return fail(f"diagnose --dask {args.dask}: " + " ".join(str(exc).split()))
    except ValueError as exc:
        return fail(f"diagnose: {exc}")
    except Interrupted as stop:   # Ctrl-C: keep the fits done so far
        return _interrupted(stop.partial, args)
    if args.out:
        from frictionrt.rt.discrepancy.diagnose import write_report
        write_folder(args.out, args.force, lambda: write_report(res, args.out))
    print(json.dumps(public(res)) if args.json else summary(res))
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
