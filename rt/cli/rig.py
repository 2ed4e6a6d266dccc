"""``frictionrt rig``: the virtual test rig (rt.discrepancy.rig), a measurement campaign with a hidden effect
of the library (rt.discrepancy.effects); ``--list`` prints the library."""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from frictionrt.rt.cli.common import add_force, add_out, fail, parse_list
from frictionrt.rt.common.files import write_folder

DESCRIPTION = """Writes a measurement campaign as a lab records it, in the measurement format
(docs/data-format.md): impulse tests at F_N1 = 40, 100, 300 N (hammer at the excitation point, 1 s
records) and actuator ramps 0 -> 150 -> 0 V over 0.3, 1 and 3 ms, each end held 30 ms (structure at
rest), with a few percent of scatter in E, mu, k_t, modal damping and c_v drawn from --seed, and
sensor noise. One effect of the library (--list) is hidden in the true structure; nothing in the
files names it.
--stepsine adds step-sine FRF tests (CSV + JSON sidecar, docs/discrepancy.md): passive, force
amplitude held at 5 and 10 N by the amplitude controller, at every F_N1 level, 18 lines 120-1250 Hz
around modes 3 and 4; the files hold the measured force and the shaker's drive amplitude per line
(shaker_interaction shows only there).
With --frf-files: measured FRFs instead (docs/data-format.md, "FRF files"): low-level accelerances
of both accelerometers with the contact stuck at each F_N1, 4-1600 Hz in 0.25 Hz lines, noise 1 %
of |H| plus 2e-3 (m/s^2)/N, as frf_01.csv, frf_02.uff, frf_03.csv with JSON sidecars; a structure
without an adaptive screw gets one test, frf_01.csv (F_N1_N = 0). Without --frf-files the campaign
needs the adaptive screw (its actuator tests). --quantity writes mobilities or receptances instead,
--force-scale S FRFs per drive volt of a shaker without force transducer (H per volt = S x H per newton).
With --frf-files --levels A,B,..: FRFs at these force amplitudes [N] from stepped-sine up-sweeps of
the nonlinear plant (the adaptive screw, if any, held at 100 N; lines around the stuck structure's
modes in 50-1200 Hz), where the joint softens as the level rises (level_NN.csv/.uff); with
--force-scale S the levels are drive voltages [V] of a shaker without force transducer.
With --excitation random the levels are rms values instead: per level a Gaussian force (drive voltage
with --force-scale) of that rms [N] ([V]) with a flat spectrum over 50-1200 Hz drives the nonlinear plant
for 92 s; the files hold H1 = S_fa / S_ff and the coherence gamma^2 = |S_fa|^2 / (S_ff S_aa) by Welch's
method (10 Hann blocks of 16 s, 50 % overlap: 0.0625 Hz lines, |H1|'s random error
sqrt(1 - gamma^2) / (gamma sqrt(20)), 2 % at gamma^2 = 0.99) on the lines of 50-1200 Hz, as a lab's
analyser exports them (rt/discrepancy/rig/random_excitation.py).
--model-form: the truth is of another model form than the nominal (half the element length and
contact pitch, two substeps, twice the interface damping, beams 0.5 % off in height and density),
so that no calibration of the nominal model fits it exactly, as with a real structure;
--model-form PARTS takes only these of its parts (mesh, pitch, substeps, damping, beams), to find
which part hides an effect (docs/discrepancy.md, "Which part of the model form hides an effect").
--refine R (with --model-form) refines its discretisation parts as a convergence study does: element
length and contact pitch / R, substeps x R^2 (R = 2: half the pitch and element length, four times
the substeps, the default plant's converged reference); without it they are halved, halved and doubled."""

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
                   "converged reference of the default plant); default: / 2, / 2 and x 2 (issue 18's form)")
    add_out(p, "DIR", "a folder it creates for the campaign's files; an existing one (not empty) is refused, or "
                      "with --force replaced as a whole")
    add_force(p, "an existing folder as a whole")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    return p


def cmd_rig(cfg, args) -> int:
    from frictionrt.rt.discrepancy.effects import EFFECTS, get
    if args.list:
        rows = [e.to_json() for e in EFFECTS.values()]
        if args.json:
            print(json.dumps({"effects": rows}))
        else:
            for r in rows:
                state = "" if r["implemented"] else "  (not implemented yet)"
                print(f"{r['name']:<20} {r['parameter']} [{r['unit']}] default {r['default_strength']:g}, "
                      f"bounds {r['bounds']}{state}")
        return 0
    if not args.effect or not args.out:
        return fail("rig: give --effect NAME (or none) and -o DIR, or --list")
    out = Path(args.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not args.force:
        return fail(f"rig -o {out}: exists; pass --force to replace it as a whole, or give a new folder")
    if args.effect != "none":
        try:
            eff = get(args.effect)
        except ValueError as exc:
            return fail(f"rig --effect: {exc}")
        if not eff.implemented:
            return fail(f"rig --effect {eff.name}: not implemented yet (needs new kernel code); implemented: "
                         + ", ".join(n for n, e in EFFECTS.items() if e.implemented))
        p = eff.parameter
        if args.strength is not None and not (math.isfinite(args.strength) and p.lo <= args.strength <= p.hi):
            return fail(f"rig --strength {args.strength:g}: {eff.name} takes {p.name} in [{p.lo:g}, {p.hi:g}] {p.unit}")
    elif args.strength is not None:
        return fail("rig --strength: --effect none takes no strength")
    if not (math.isfinite(args.record_s) and 0.2 <= args.record_s <= 10.0):
        return fail(f"rig --record-s {args.record_s:g}: give 0.2 .. 10 s")
    if args.frf_files and (args.stepsine or args.record_s != 1.0):
        return fail("rig --frf-files: --stepsine and --record-s apply to the time-series campaign only; drop them")
    if not args.frf_files and (args.quantity != "accelerance" or args.force_scale is not None):
        return fail("rig --quantity, --force-scale: they apply to --frf-files only; add it or drop them")
    if args.force_scale is not None and not (math.isfinite(args.force_scale) and args.force_scale > 0):
        return fail(f"rig --force-scale {args.force_scale:g}: give a force per volt > 0 [N/V]")
    if args.levels is not None and not args.frf_files:
        return fail("rig --levels: the level tests are FRF files; add --frf-files")
    if args.levels is not None and args.quantity != "accelerance":
        return fail("rig --levels: the level tests are accelerances; --quantity applies to the linear FRF files "
                    "only, drop it")
    if args.excitation != "stepsine" and args.levels is None:
        return fail(f"rig --excitation {args.excitation}: it drives the level tests; add --frf-files --levels A,B,..")
    levels = None
    if args.levels is not None:
        try:
            levels = parse_list(args.levels, float, "rig --levels", "0.5,1,2,5")
        except ValueError as exc:
            return fail(str(exc))
    from frictionrt.rt.discrepancy.rig import make_campaign, model_form, model_form_parts, model_form_refine
    try:
        form = model_form_parts(args.model_form)
    except ValueError as exc:
        return fail(f"rig --model-form: {exc}")
    if args.refine is not None and not form:
        return fail(f"rig --refine {args.refine}: it refines the truth's model form; add --model-form (all or PARTS)")
    try:
        refine = model_form_refine(args.refine, form)
    except ValueError as exc:
        return fail(f"rig --refine {args.refine}: {exc}")
    if refine is not None:
        try:
            model_form(cfg, form, refine)
        except ValueError as exc:
            return fail(f"rig --refine {refine}: the refined truth is not a valid configuration ({exc}); "
                        "give a smaller factor")
    from frictionrt.rt.discrepancy.rig import make_frf_campaign, make_level_campaign

    def write():   # the campaign into the new folder out (moved in once complete; rt.discrepancy.rig.new_folder)
        if levels is not None:
            return make_level_campaign(out, args.effect, args.strength, seed=args.seed, cfg=cfg, force_levels_n=levels,
                                       other_form=form, force_scale_N_per_V=args.force_scale,
                                       excitation=args.excitation, refine=refine,
                                       progress=lambda msg: print(f"rig: {msg}", file=sys.stderr))
        if args.frf_files:
            return make_frf_campaign(out, args.effect, args.strength, seed=args.seed, cfg=cfg, quantity=args.quantity,
                                     force_scale_N_per_V=args.force_scale, other_form=form, refine=refine)
        return make_campaign(out, args.effect, args.strength, seed=args.seed, cfg=cfg, record_s=args.record_s,
                             stepsine=args.stepsine, other_form=form, refine=refine)

    try:
        files = write_folder(out, args.force, write)
    except ValueError as exc:
        return fail(f"rig -o: {exc}")
    if args.json:
        print(json.dumps({"folder": args.out, "files": [str(f) for f in files]}))
    else:
        print(f"{len(files)} files in {args.out}: " + ", ".join(f.name for f in files))
    return 0
