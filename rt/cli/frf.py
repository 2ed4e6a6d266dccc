"""``frictionrt frf``: step-sine FRFs of the closed loop (rt.experiments.stepsine), per law and force amplitude.

``add_parser(subparsers)`` registers the subcommand, ``cmd_frf(cfg, args)`` runs it and returns the
exit code (0 done, 2 bad input with one line on stderr, as every frictionrt command).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from frictionrt.rt.common.config import LAWS, Config, dumps
from frictionrt.rt.cli.structure import add_structure, structure_arg
from frictionrt.rt.cli.common import (CommaList, add_estimator, add_common, add_controller, add_force, add_out, c_exports, controller_for, fail,
                           parse_list, refuse_existing)

DESCRIPTION = """Step-sine accelerance FRF H = a(x = 0.45 m) / F_exc [(m/s^2)/N] of the closed loop, as the
paper measures it: at each frequency the loop runs in blocks of whole periods, the excitation force
amplitude [N] is held on the measured force, and the point is measured once H has settled (or flagged
"settled: false" after --max-time). Frequencies are swept in order, each point continuing from the
previous one's state; one sweep per law and amplitude, run in parallel."""

EXAMPLES = """examples:
  frictionrt frf --law passive,lyapunov --amps 5 --around-modes 3 --plot logs/frf_mode3.png
  frictionrt frf --law hysteresis --amps 5,20 --freqs 190,195,200,205 --down --json
  frictionrt frf --law passive --amps 5 --around-modes 2,3,4,5 --dask tcp://10.0.0.5:8786 --out logs/frf.json
  frictionrt frf --law passive --amps 5 --freqs 185,205 --sweep-rate 0.5 --down --plot logs/sweep_down.png"""


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    """Register ``frf`` on an argparse subparsers object; parents default to frictionrt's
    --config/--set parser (so they are accepted after the subcommand too)."""
    if parents is None:
        common = argparse.ArgumentParser(add_help=False)
        add_common(common, top=False)
        parents = [common]
    p = subparsers.add_parser("frf", parents=parents, help="step-sine FRF [(m/s^2)/N] per law and force amplitude",
                              description=DESCRIPTION, epilog=EXAMPLES)
    p.add_argument("--law", "--laws", action=CommaList, kind=str, allowed=LAWS, required=True, metavar="LAW1,LAW2",
                   example="passive,lyapunov", help=f"control law(s), comma-separated, one sweep each: {', '.join(LAWS)}")
    add_estimator(p)
    p.add_argument("--amps", "--amp", action=CommaList, kind=float, required=True, metavar="N1,N2",
                   help="excitation force amplitude(s) [N] held on the measured force, comma-separated, one sweep "
                        "each (> 0)")
    grid = p.add_mutually_exclusive_group(required=True)
    grid.add_argument("--freqs", metavar="F1,F2,...",
                      help="explicit frequencies [Hz], comma-separated, below the Nyquist frequency (10500 Hz at "
                           "21 kHz); swept in increasing order (decreasing with --down)")
    grid.add_argument("--around-modes", metavar="M1,M2,...",
                      help="bending modes to resolve, e.g. 2,3,4,5 (the paper's; mode 1 is at 9.8 Hz): --points "
                           "frequencies over +/- --half-width around the middle of each mode's band between the "
                           "adaptive screw's pair sliding and stuck (rt.experiments.stepsine.mode_bands_hz)")
    p.add_argument("--points", type=int, default=31, metavar="N",
                   help="frequencies per mode with --around-modes (31: 1 %% steps over +/-15 %%)")
    p.add_argument("--half-width", type=float, default=0.15, metavar="REL",
                   help="half width of each mode's band, relative to its centre")
    p.add_argument("--down", action="store_true",
                   help="sweep from the highest frequency down; a nonlinear FRF can differ (default: up)")
    p.add_argument("--sweep-rate", type=float, default=None, metavar="HZ_PER_S",
                   help="instead of step-sine points: a slow continuous sweep (phase-continuous, force amplitude "
                        "held) over the grid's range at this rate [Hz/s] (> 0; the paper sweeps at <= 0.1 Hz/s; "
                        "--down sweeps down), one point per ~0.1 s dwell, after a 4 s lead-in")
    p.add_argument("--tol", type=float, default=0.01, metavar="REL",
                   help="settled when H's predicted remaining change is below this (relative)")
    p.add_argument("--max-time", type=float, default=8.0, metavar="S",
                   help="simulated time per frequency [s] before the point is measured as not settled")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="local worker processes, one sweep each at a time (default: the number of cores)")
    p.add_argument("--dask", metavar="tcp://HOST:PORT",
                   help="run the sweeps on this dask scheduler's workers instead (frictionrt installed there)")
    add_controller(p, many=True)
    p.add_argument("--error-estimate", action="store_true",
                   help="also sweep the same points with the contact pitch and the elements x2 and give the "
                        "estimated discretisation error of each |H| and of each sweep's peak [dB] (Richardson, "
                        "order 1: refined - this = this - coarse); about as long again")
    p.add_argument("--json", action="store_true", help="print the results as one JSON object (no progress bar)")
    p.add_argument("--plot", metavar="PATH.png", help="write |H| [dB] and phase [deg] against f [Hz] here (PNG)")
    add_out(p, "PATH.json", "the file to write the results to (JSON; --plot and --rrd: the same FRFs as plot and "
                            "recording)")
    add_force(p)
    p.add_argument("--rrd", metavar="PATH.rrd", help="write the FRFs as a rerun recording here (|H| [dB], phase, "
                   "force amplitude against frequency; open with: rerun PATH.rrd)")
    add_structure(p)
    return p


def _frequencies(cfg: Config, args, structure=None, designs=None) -> list[float]:
    """The sweep's frequencies [Hz], in sweep order; ValueError naming the option. structure: an
    imported structure whose modes --around-modes resolves (designs: its plant, built once)."""
    from frictionrt.rt.experiments.stepsine import mode_bands_hz, resonance_grid
    nyq = 0.5 / cfg.dt_s
    if args.freqs is not None:
        freqs = parse_list(args.freqs, float, "--freqs", "190,195,200")
        for f in freqs:
            if not (math.isfinite(f) and 0.0 < f < nyq):
                raise ValueError(f"--freqs {f:g} Hz: must lie in (0, {nyq:g}) Hz (below the Nyquist frequency)")
    else:
        modes = parse_list(args.around_modes, int, "--around-modes", "2,3,4,5")
        if args.points < 2:
            raise ValueError(f"--points {args.points}: need at least 2 frequencies per mode")
        if not 0.0 < args.half_width < 1.0:
            raise ValueError(f"--half-width {args.half_width:g}: must lie in (0, 1), e.g. 0.15")
        try:
            bands = mode_bands_hz(cfg, modes, designs, structure)
        except ValueError as exc:
            raise ValueError(f"--around-modes {args.around_modes}: {exc}") from None
        freqs = resonance_grid([0.5 * (lo + hi) for lo, hi in bands.values()], args.half_width, args.points).tolist()
        if freqs[-1] >= nyq:
            raise ValueError(f"--around-modes {args.around_modes}: the grid reaches {freqs[-1]:g} Hz, at or above "
                             f"the Nyquist frequency {nyq:g} Hz; lower --half-width or the modes")
    return sorted(set(freqs), reverse=args.down)


def _table(r) -> str:
    import numpy as np
    lines = [f"{r.law}, {r.amp_n:g} N, {r.direction}-sweep, estimator {r.estimator}",
             (f"{'f [Hz]':>9} {'|H| [(m/s^2)/N]':>16} {'phase [deg]':>12} {'a [m/s^2]':>10} {'F [N]':>8} "
              f"{'THD [%]':>8} {'F_N1 [N]':>9} {'E [J]':>9} {'t [s]':>6} {'settled':>7}")]
    for i in range(len(r.freq_hz)):
        lines.append(f"{r.freq_hz[i]:>9.2f} {r.H_abs[i]:>16.4g} {np.degrees(r.phase_rad[i]):>12.1f} "
                     f"{r.a_amp[i]:>10.4g} {r.F_amp[i]:>8.4g} {100 * r.thd[i]:>8.1f} {r.F_N1_mean[i]:>9.1f} "
                     f"{r.energy_j[i]:>9.3g} {r.settle_s[i]:>6.2f} {'yes' if r.settled[i] else 'NO':>7}")
    return "\n".join(lines)


def cmd_frf(cfg: Config, args) -> int:
    """Run ``frictionrt frf``: validate, sweep every (law, amplitude) in parallel, print or write
    (JSON: dt_s, the resolved configuration as TOML, the controller of each law (c:DIR or numba),
    one ``StepSineResult.to_dict()`` per sweep)."""
    from frictionrt.rt.experiments.branches import Branch, run_branches
    from frictionrt.rt.experiments.stepsine import Settle, plot_frfs
    for a in args.amps:
        if not (math.isfinite(a) and a > 0.0):
            return fail(f"--amp {a:g} N: an FRF needs a finite force amplitude > 0 N")
    if args.jobs is not None and args.jobs < 1:
        return fail(f"--jobs {args.jobs}: must be >= 1")
    paths = {}
    for option, value, suffix in (("--plot", args.plot, ".png"), ("--out", args.out, ".json"),
                                  ("--rrd", args.rrd, ".rrd")):
        if value:
            path = Path(value)
            if path.suffix.lower() != suffix or not path.parent.exists():
                return fail(f"{option} {value}: give a {suffix} file in an existing folder")
            if msg := refuse_existing([path], args.force, option):
                return fail(msg)
            paths[option] = path
    rate = args.sweep_rate
    if rate is not None and not (math.isfinite(rate) and rate > 0.0):
        return fail(f"--sweep-rate {rate:g} Hz/s: must be a finite rate > 0 (e.g. 0.5; --down for a down-sweep)")
    if args.structure and args.error_estimate:
        return fail("--error-estimate with --structure: not on an imported structure (its refinement is the FE "
                    "code's); drop it")
    from frictionrt.rt.loop import Designs
    designs = Designs()   # the structure's plant, built once for the bands and the loops
    try:
        structure = structure_arg(args)
        freqs = _frequencies(cfg, args, structure, designs)
        settle = Settle(rel_tol=args.tol, max_s=args.max_time)
        if rate is None:
            settle.check(freqs, cfg.dt_s)
    except ValueError as exc:
        msg = str(exc).replace("settle.rel_tol", "--tol").replace("settle.max_s", "--max-time")
        return fail(msg)
    if rate is not None:
        if len(freqs) < 2:
            return fail("--sweep-rate: the frequency range is a single frequency; give two or more --freqs")
        freqs = [freqs[0], freqs[-1]]   # the range, in sweep order
        rate = -rate if args.down else rate
    branches = [Branch(cfg, law, a, tuple(freqs), args.estimator, settle, sweep_rate_hz_s=rate, structure=structure)
                for law in args.law for a in args.amps]
    loops = None
    try:
        if structure is not None:
            from frictionrt.rt.experiments.branches import build_loops
            loops = build_loops(branches, designs)
        exports = c_exports(args.controller, [(law, args.estimator) for law in dict.fromkeys(args.law)])
        if exports:   # each law with a C export runs it (its worker processes load the library by path)
            from dataclasses import replace
            from frictionrt.rt.experiments.branches import build_loops
            loops = loops if loops is not None else build_loops(branches)
            ctrl = {id(lp): controller_for(exports, lp, cfg.rt.seed) for lp in loops}
            branches = [replace(b, controller=ctrl[id(lp)]) for b, lp in zip(branches, loops)]
        results = run_branches(branches, jobs=args.jobs, dask_address=args.dask, progress=not args.json, loops=loops)
    except ConnectionError as exc:
        return fail(f"--dask {args.dask}: " + " ".join(str(exc).split()))
    except ValueError as exc:
        return fail(str(exc))
    controllers = {law: f"c:{exports[law, args.estimator]}" if (law, args.estimator) in exports else "numba"
                   for law in dict.fromkeys(args.law)}
    doc = {"dt_s": cfg.dt_s, "config": dumps(cfg), "controllers": controllers,
           "results": [r.to_dict() for r in results]}
    if structure is not None:
        doc["structure"] = json.loads(structure.record())
    if args.error_estimate:
        from dataclasses import replace
        from frictionrt.rt.experiments.discretisation import coarser, refined_shift
        coarse_cfg = coarser(cfg)
        coarse = run_branches([replace(b, cfg=coarse_cfg, controller=None) for b in branches], jobs=args.jobs,
                              dask_address=args.dask, progress=not args.json)
        doc["error_estimate"] = [
            {"law": r.law, "amp_n": r.amp_n,
             "H_shift_db": [refined_shift(20 * math.log10(a), 20 * math.log10(b)) for a, b in zip(r.H_abs, c.H_abs)],
             "peak_shift_db": refined_shift(20 * math.log10(r.H_abs.max()), 20 * math.log10(c.H_abs.max()))}
            for r, c in zip(results, coarse)]
    if "--out" in paths:
        tmp = paths["--out"].with_suffix(".tmp.json")
        tmp.write_text(json.dumps(doc))
        tmp.replace(paths["--out"])  # never leave a half-written file
    if "--plot" in paths:
        tmp = paths["--plot"].with_suffix(".tmp.png")
        plot_frfs(results, str(tmp))
        tmp.replace(paths["--plot"])
    if "--rrd" in paths:
        from frictionrt.rt.log.rrd_log import write_frf_rrd
        write_frf_rrd(paths["--rrd"], results, {"config": dumps(cfg)})
    unsettled = sum(int((~r.settled).sum()) for r in results)
    if unsettled:
        print(f"frictionrt frf: {unsettled} of {sum(len(r.freq_hz) for r in results)} points did not settle "
              f"within --max-time {args.max_time:g} s (settled: false); they are measured over their last blocks",
              file=sys.stderr)
    if args.json:
        print(json.dumps(doc))
        return 0
    if exports:
        print("controller: " + ", ".join(f"{law} {c}" for law, c in controllers.items()))
    if structure is not None:
        print(f"imported structure {structure.path}" + (f", coarsened to {structure.clusters} points"
                                                         if structure.clusters else ""))
    if args.error_estimate:
        print("\n\n".join(_table(r) + f"\ndiscretisation: peak |H| {e['peak_shift_db']:+.2f} dB, points "
                           + ", ".join(f"{x:+.2f}" for x in e["H_shift_db"]) + " dB (estimated shift under "
                           "refinement: Richardson from the contact pitch and elements x2, order 1)"
                           for r, e in zip(results, doc["error_estimate"])))
    else:
        print("\n\n".join(_table(r) for r in results))
    for option, path in paths.items():
        print(f"{option[2:]}: {path}")
    return 0
