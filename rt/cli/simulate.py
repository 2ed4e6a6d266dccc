"""``frictionrt simulate``: the closed loop at 21 kHz (rt.loop) with a sine excitation, optionally logged;
with --controller c:DIR the C export in DIR is the loop's controller (software in the loop, rt.export.sil)."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from frictionrt.rt.cli.structure import add_structure, structure_simulate
from frictionrt.rt.cli.common import (spec_default, add_estimator, add_controller, add_force, add_out, add_realtime, c_exports, controller_for, deprecated,
                           fail, realtime_notes, refuse_existing, unpaced_realtime)


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``simulate`` (parents: frictionrt's --config/--set parser)."""
    s = sub.add_parser("simulate", parents=parents, help="closed loop at 21 kHz: sine excitation, a law, the actuator",
                       description="Run the closed loop (sensors -> estimator -> law -> force tracking -> "
                                   "actuator -> plant) with a sine excitation force of --amp [N] at --freq [Hz] "
                                   "for --duration [s]; print the summary (acceleration at x = 0.45 m [m/s^2], "
                                   "mean F_N1 [N], actuator energy [J], overruns); with --out, log every signal "
                                   "to PATH.mcap and PATH.rrd while the loop runs.")
    s.add_argument("--law", choices=["passive", "hysteresis", "lyapunov"], default=None,
                   help=f"control law (default: {spec_default('tracking.law')})")
    add_estimator(s)
    s.add_argument("--freq", type=float, required=True, metavar="HZ", help="excitation frequency [Hz]")
    s.add_argument("--amp", type=float, required=True, metavar="N", help="excitation force amplitude [N]")
    s.add_argument("--duration", type=float, default=1.0, metavar="S", help="simulated time [s]")
    s.add_argument("--paced", action="store_true", help="pace the ticks to the wall clock (21 kHz)")
    add_realtime(s)
    s.add_argument("--seed", type=int, default=None, metavar="N", help=f"sensor noise seed (default: {spec_default('rt.seed')})")
    add_out(s, "NAME.mcap", "the file to write the log to, NAME.mcap (.mcap added if missing), with its rerun "
                            "recording NAME.rrd and Foxglove layout NAME.foxglove.json beside it; the folder must exist")
    add_force(s)
    s.add_argument("--no-rrd", action="store_true", help="with --out: write the MCAP file only")
    s.add_argument("--ring", type=float, default=1.0, metavar="S",
                   help="with --out: the log is a ring of S seconds [s] (whole 0.1 s blocks) that the writer "
                        "drains; offline the loop waits for it, paced it overwrites and the writer drops and "
                        "counts those blocks")
    s.add_argument("--fault", action="append", default=[], metavar="KIND[/SENSOR][=VALUE]@TIME[:DURATION]",
                   help="inject a fault at TIME [s] for DURATION [s] (default: to the end); repeatable. KIND: "
                        "sensor_dropout, sensor_stuck, sensor_gain, sensor_bias (SENSOR a_tip (default), a_frf, "
                        "F_strain, F_cell), actuator_loss, force_saturation, observer_mismatch, cpu_stall (--paced); "
                        "VALUE and what the supervisor makes of it: docs/reliability.md")
    add_controller(s)
    s.add_argument("--json", action="store_true", help="the summary as one JSON object")
    add_structure(s)
    s.add_argument("--plant-only", action="store_true",
                   help="with --structure: the imported plant alone with the passive joint (constant F_N1), no "
                        "actuator or controller; prints its step's wall time and Newton iterations")
    return s


def cmd_simulate(cfg, args) -> int:
    if args.structure and args.plant_only:
        return structure_simulate(cfg, args)
    if args.plant_only:
        return fail("--plant-only: with --structure FILE only (the imported plant alone, passive joint)")
    if args.structure and args.paced:
        return fail("--paced with --structure: not on an imported structure yet; drop it (the loop runs offline)")
    from frictionrt.jobs import simulate
    from frictionrt.rt.log.writer import INTERRUPT_DRAIN_S
    if msg := unpaced_realtime(args):
        return fail(msg)
    if args.out:
        base = Path(args.out)
        if base.suffix == ".rrd":   # the old spelling: the stem of all three files
            deprecated(f"-o {args.out}", f"-o {base.with_suffix('.mcap')}")
        if base.suffix in (".mcap", ".rrd"):
            base = base.with_suffix("")
        if not base.parent.exists():
            return fail(f"--out {args.out}: folder {base.parent} does not exist")
        outputs = [base.with_name(base.name + s) for s in (".mcap", ".foxglove.json", *(() if args.no_rrd else (".rrd",)))]
        if msg := refuse_existing(outputs, args.force):
            return fail(msg)
    try:
        seed = cfg.rt.seed if args.seed is None else args.seed
        exports = c_exports(args.controller, [(args.law or cfg.tracking.law, args.estimator)])
        res = simulate(cfg, freq_hz=args.freq, amp_n=args.amp, law=args.law, estimator=args.estimator,
                       duration_s=args.duration, paced=args.paced, seed=args.seed, out=args.out, force=args.force,
                       rrd=not args.no_rrd, ring_s=args.ring, faults=args.fault, progress=not args.json,
                       controller_of=(lambda loop: controller_for(exports, loop, seed)) if exports else None,
                       structure=args.structure, clusters=args.clusters, clustering=args.clustering)
    except ValueError as exc:
        return fail(str(exc).replace("freq_hz (--freq)", "--freq").replace("ring ", "--ring ", 1)
                    if str(exc).startswith(("freq_hz", "ring ")) else str(exc))
    except KeyboardInterrupt as exc:
        if str(exc).startswith("interrupted before"):
            return fail(str(exc))
        raise
    s = res.to_dict()
    realtime_notes(s.get("realtime"))
    if args.json:
        print(json.dumps(s))
        return 130 if s["interrupted"] else 0
    if s["interrupted"]:
        print(f"interrupted (Ctrl-C) after {s['ticks']} ticks: the summary covers those, the log all but "
              f"{s.get('unwritten_ticks', 0)} (the writer stops {INTERRUPT_DRAIN_S} s after a Ctrl-C)")
    print(f"law {s['law']}, estimator {s['estimator']}, {s['amp_n']:g} N at {s['freq_hz']:g} Hz, {s['ticks']} ticks"
          f"{' (paced)' if s['paced'] else ''}")
    print(f"acceleration at x = 0.45 m (last 20 %): first harmonic {s['acc045_amplitude']:.4g} m/s^2; raw RMS "
          f"{s['acc045_rms']:.4g}, peak {s['acc045_peak']:.4g} (raw: mostly unresolved-mode ringing above 5 kHz, "
          f"docs/plant.md 2.6)")
    print(f"mean F_N1 {s['fn1_mean_n']:.2f} N, actuator energy {s['actuator_energy_j']:.4g} J, "
          f"tick median {s['tick_median_us']:.2f} us, overruns {s['overruns']}")
    if "v_rel_nrmse" in s:
        print(f"estimation (last 20 %, against the plant's band-limited truth): NRMSE v_rel {s['v_rel_nrmse']:.3f}, "
              f"u_rel {s['u_rel_nrmse']:.3f}; RT1 amplitude u0 error {100 * s['u0_rel_error']:+.1f} %; "
              f"sign error of v_rel (|v_rel|-weighted) {s['v_rel_sign_error']:.3f}"
              + (f"; Lyapunov command F* error rms {s['fstar_rms_error_n']:.1f} N, mean {s['fstar_mean_error_n']:+.1f} N"
                 if "fstar_rms_error_n" in s else ""))
    for f in s["faults"]:
        print(f"fault {f['kind']}{'/' + f['sensor'] if f['sensor'] else ''} at tick {f['tick']}: "
              + (f"{f['name']} (code {f['code']}) detected at tick {f['detected_tick']}, passive at tick "
                 f"{f['passive_tick']}" if f["detected_tick"] is not None else "not detected"))
    if s["trips"] and not s["faults"]:
        print("supervisor: " + ", ".join(f"{t['name']} (code {t['code']}) at tick {t['tick']}" for t in s["trips"]))
    if "mcap" in s:
        print(f"log: {s['mcap']}{', ' + s['rrd'] if s['rrd'] else ''}; dropped blocks {s['dropped_blocks']}; "
              f"Foxglove layout {s['foxglove_layout']}")
    return 130 if s["interrupted"] else 0
