"""``frictionrt rig``: the virtual test rig (rt.discrepancy.rig), a measurement campaign with a hidden effect
of the library (rt.discrepancy.effects); ``--list`` prints the library."""
from __future__ import annotations

import argparse
import json
import sys

from frictionrt.rt.cli.common import add_force, add_out, fail, parse_list

DESCRIPTION = """Writes a measurement campaign of the configured structure as a lab records it, with one
effect of the library (--list) hidden in the true structure, a few percent of scatter and sensor
noise: impulse and actuator tests as MCAP logs (--stepsine adds step-sine FRF tests); with
--frf-files FRF files (CSV/UFF with JSON sidecars) of the stuck contact; with --frf-files --levels
FRFs of the nonlinear plant at several force amplitudes (--excitation random: rms levels, H1 and
coherence). --model-form gives the truth another model form than the nominal. What each test holds,
its lines and noise: docs/discrepancy.md, "The virtual rig"."""

EXAMPLES = """examples:
  frictionrt rig --list
  frictionrt rig --effect accelerometer_mass -o logs/campaign_acc
  frictionrt rig --effect current_limit --strength 0.2 --seed 4 -o logs/campaign_il
  frictionrt rig --effect none -o logs/campaign_clean && frictionrt diagnose logs/campaign_clean
  frictionrt rig --effect clamp_compliance --frf-files -o logs/frf_clamp && frictionrt diagnose logs/frf_clamp
  frictionrt rig --effect shaker_interaction --stepsine --seed 3 -o logs/campaign_shaker
  frictionrt rig --effect moving_mass --frf-files --quantity mobility --force-scale 0.37 -o logs/frf_volt

  frictionrt rig --effect micro_slip --frf-files --levels 0.5,1,2,5,10,20 -o logs/frf_levels
  frictionrt rig --effect micro_slip --frf-files --levels 1,2,5,10,20 --excitation random -o logs/frf_random
  frictionrt rig --effect moving_mass --model-form -o logs/campaign_form && frictionrt diagnose logs/campaign_form
  frictionrt rig --effect micro_slip --model-form damping,beams -o logs/campaign_form2
  frictionrt rig --effect stribeck --model-form all --refine 2 --seed 3 -o logs/campaign_refined"""


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    p = subparsers.add_parser("rig", parents=parents or [], help="virtual test rig: a measurement campaign "
                              "with a hidden effect", description=DESCRIPTION, epilog=EXAMPLES)
    p.add_argument("--list", action="store_true", help="print the effects library (name, parameter, unit, "
                   "default strength, bounds, implemented) and exit")
    p.add_argument("--effect", metavar="NAME", help="effect hidden in the true structure (see --list), or none")
    p.add_argument("--strength", type=float, metavar="S",
                   help="effect strength in the parameter's unit (default: its moderate strength, --list)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the scatter, hammer hits and noise")
    p.add_argument("--record-s", type=float, default=1.0, metavar="S", help="impulse record length [s]")
    p.add_argument("--frf-files", action="store_true", help="write FRF files (CSV/UFF + JSON sidecars: linear, "
                   "contact stuck, at each F_N1) instead of the time-series campaign (rt/discrepancy/rig/frf.py)")
    p.add_argument("--quantity", choices=("accelerance", "mobility", "receptance"), default="accelerance",
                   help="with --frf-files: what the files hold, (m/s^2)/N, (m/s)/N or m/N")
    p.add_argument("--force-scale", type=float, metavar="N_PER_V",
                   help="with --frf-files: the excitation is a drive voltage without force measurement, the "
                        "files hold H per volt = N_PER_V x H per newton (sidecar excitation drive_voltage)")
    p.add_argument("--stepsine", action="store_true", help="also step-sine FRF tests (passive, force amplitude "
                   "held at 5 and 10 N, every F_N1 level, 18 lines 120-1250 Hz) as CSV + JSON sidecar")
    p.add_argument("--levels", metavar="A,B,..", help="with --frf-files: force amplitudes [N] (drive voltages [V] with --force-scale) of stepped-sine "
                   "tests of the nonlinear plant, one file per level (rt/discrepancy/rig/levels.py), instead of "
                   "the linear FRFs at three F_N1")
    p.add_argument("--excitation", choices=("stepsine", "random"), default="stepsine",
                   help="with --frf-files --levels: stepped sines of those amplitudes (default), or band-limited "
                   "random excitation of those rms values over 50-1200 Hz, H1 and coherence by Welch (16 s Hann "
                   "blocks, 10 averages, 50 %% overlap: 0.0625 Hz lines)")
    p.add_argument("--model-form", nargs="?", const="all", metavar="PARTS",
                   help="the truth of another model form: finer mesh and contact pitch, substeps, other interface "
                   "damping, beams not copies of the nominal's (rt.discrepancy.rig.model_form); PARTS: all "
                   "(without PARTS) or a comma-separated subset of mesh,pitch,substeps,damping,beams")
    p.add_argument("--refine", metavar="R", help="with --model-form: its mesh, pitch and substeps parts refine the "
                   "nominal's by a whole number R >= 2 (element length and pitch / R, substeps x R^2; 2 is the "
                   "converged reference of the default plant); default: / 2, / 2 and x 2)")
    add_out(p, "DIR", "a folder it creates for the campaign's files; an existing one (not empty) is refused, or "
                      "with --force replaced as a whole")
    add_force(p, "an existing folder as a whole")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    return p


def cmd_rig(cfg, args) -> int:
    from frictionrt.jobs import effects, rig
    if args.list:
        res = effects()
        print(res.to_json() if args.json else str(res))
        return 0
    if not args.effect or not args.out:
        return fail("rig: give --effect NAME (or none) and -o DIR, or --list")
    levels = None
    if args.levels is not None:
        try:
            levels = parse_list(args.levels, float, "rig --levels", "0.5,1,2,5")
        except ValueError as exc:
            return fail(str(exc))
    try:
        res = rig(cfg, effect=args.effect, out=args.out, strength=args.strength, seed=args.seed,
                  record_s=args.record_s, stepsine=args.stepsine, frf_files=args.frf_files, quantity=args.quantity,
                  force_scale=args.force_scale, levels=levels, excitation=args.excitation,
                  model_form=args.model_form, refine=args.refine, force=args.force,
                  progress=lambda msg: print(f"rig: {msg}", file=sys.stderr))
    except (ValueError, FileExistsError) as exc:
        return fail(str(exc))
    if args.json:
        print(json.dumps({"folder": args.out, "files": res["files"]}))
    else:
        print(res)
    return 0
