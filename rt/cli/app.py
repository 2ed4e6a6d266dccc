"""``frictionrt``: the command-line entry point (one console script, subcommands).

Every subcommand takes ``--config FILE`` and ``--set KEY=VALUE`` (repeatable); quantities
are SI (m, s, N, Hz, Pa, kg) everywhere. Bad input ends with exit code 2 and one message
naming the input and the problem.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from rt.cli.frf import add_parser as add_frf_parser, cmd_frf
from rt.cli.replay_plant import cmd_replay_plant
from rt.cli.validate import add_parser as add_validate_parser, cmd_validate
from rt.cli.reproduce import add_parser as add_reproduce_parser, cmd_reproduce
from rt.cli.tune import add_parser as add_tune_parser, cmd_tune
from rt.cli import diagnose as cli_diagnose, export_c as cli_export_c, rig as cli_rig
from rt.cli.log import add_parsers as add_log_parsers, cmd_inspect, cmd_recover
from rt.cli.common import (Parser, actuator_verb, add_common, add_force, add_out, add_realtime, fail, json_errors,
                           realtime_notes, realtime_sets, refuse_existing, unpaced_realtime)
from rt.common.config import ConfigError, adaptive_screw, dumps, load, require_adaptive_screw, to_dict

EPILOG = """units: SI throughout (m, s, N, N/m, Hz, Pa, kg/m^3); forces in N, frequencies in Hz.
examples:
  frictionrt config --show
  frictionrt --set plant.interface.mu=0.3 modes --json
  frictionrt impulse --fn1 100 --plot logs/impulse.png
  frictionrt simulate --law lyapunov --freq 223.6 --amp 5 --duration 1 --out logs/lyap
  frictionrt replay logs/lyap.mcap
  frictionrt budget
  frictionrt bench plant --json"""


def version_text() -> str:
    """frictionrt's version and the log format it writes."""
    from importlib.metadata import version

    from rt.log.mcap_log import FORMAT_VERSION
    return f"frictionrt {version('frictionrt')} (log format {FORMAT_VERSION})"


def build_parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    add_common(common, top=False)
    ap = Parser(
        prog="frictionrt", epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Real-time emulation of semi-actively controlled friction dampers (Becker & Gaul).")
    ap.add_argument("--version", action="version", version=version_text())
    add_common(ap, top=True)
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")

    c = sub.add_parser("config", parents=[common], help="print the resolved configuration",
                       description="Print the resolved configuration (defaults <- --config <- --set) as TOML "
                                   "with units, or as JSON. The TOML output is a valid --config file.")
    c.add_argument("--show", action="store_true", help="print it (the default action)")
    c.add_argument("--json", action="store_true", help="JSON instead of TOML")

    m = sub.add_parser("modes", parents=[common], help="eigenfrequencies [Hz]: bare beam, full and reduced model",
                       description="Eigenfrequencies [Hz] of the bare main beam, and of the assembly with the "
                                   "contact linearised as stuck: full FE and Craig-Bampton model; DOF counts; "
                                   "the effective tangential stiffness k_T [N/m] at the adaptive screw (if the "
                                   "structure has one; docs/plant.md 5.3).")
    m.add_argument("--json", action="store_true", help="one JSON object instead of a table")

    i = sub.add_parser("impulse", parents=[common], help="simulated hammer test: accelerance FRF, modal damping",
                       description="Hammer impulse (half-sine, impulse.peak_N [N], impulse.duration_s [s]) at "
                                   "the excitation point with constant F_N1 [N]; accelerance FRF "
                                   "[(m/s^2)/N] at the FRF point; natural frequencies [Hz] and damping "
                                   "ratios [-] of bending modes 2-5.")
    i.add_argument("--fn1", type=float, default=None, metavar="N",
                   help="adaptive screw force F_N1 [N] (default: plant.screws.adaptive.F_N); refused for a "
                        "structure without an adaptive screw")
    i.add_argument("--plot", metavar="FILE", help="write the FRF plot (PNG) here")
    add_force(i)
    i.add_argument("--json", action="store_true", help="one JSON object instead of a table")

    s = sub.add_parser("simulate", parents=[common], help="closed loop at 21 kHz: sine excitation, a law, the actuator",
                       description="Run the closed loop (sensors -> estimator -> law -> force tracking -> "
                                   "actuator -> plant) with a sine excitation force of --amp [N] at --freq [Hz] "
                                   "for --duration [s]; print the summary (acceleration at x = 0.45 m [m/s^2], "
                                   "mean F_N1 [N], actuator energy [J], overruns); with --out, log every signal "
                                   "to PATH.mcap and PATH.rrd while the loop runs.")
    s.add_argument("--law", choices=["passive", "hysteresis", "lyapunov"], default=None,
                   help="control law (default: tracking.law)")
    s.add_argument("--estimator", choices=["oracle", "observer"], default="oracle",
                   help="oracle: the plant's band-limited u_rel, v_rel; observer: the Kalman-designed nonlinear observer on the tip accelerometer and the force cell (docs/observer.md)")
    s.add_argument("--freq", type=float, required=True, metavar="HZ", help="excitation frequency [Hz]")
    s.add_argument("--amp", type=float, required=True, metavar="N", help="excitation force amplitude [N]")
    s.add_argument("--duration", type=float, default=1.0, metavar="S", help="simulated time [s] (default 1)")
    s.add_argument("--paced", action="store_true", help="pace the ticks to the wall clock (21 kHz)")
    add_realtime(s)
    s.add_argument("--seed", type=int, default=None, metavar="N", help="sensor noise seed (default: rt.seed)")
    add_out(s, "PATH", "write the log to PATH.mcap, PATH.rrd and its Foxglove layout PATH.foxglove.json (a "
                       ".mcap or .rrd suffix is dropped); the folder must exist")
    add_force(s)
    s.add_argument("--no-rrd", action="store_true", help="with --out: write the MCAP file only")
    s.add_argument("--ring", type=float, default=1.0, metavar="S",
                   help="with --out: the log is a ring of S seconds [s] (whole 0.1 s blocks) that the writer "
                        "drains; offline the loop waits for it, paced it overwrites and the writer drops and "
                        "counts those blocks (default 1)")
    s.add_argument("--fault", action="append", default=[], metavar="KIND[/SENSOR][=VALUE]@TIME[:DURATION]",
                   help="inject a fault at TIME [s] for DURATION [s] (default: to the end); repeatable. KIND: "
                        "sensor_dropout, sensor_stuck, sensor_gain, sensor_bias (SENSOR a_tip (default), a_frf, "
                        "F_strain, F_cell), actuator_loss, force_saturation, observer_mismatch, cpu_stall (--paced); "
                        "VALUE and what the supervisor makes of it: docs/reliability.md")
    s.add_argument("--json", action="store_true", help="the summary as one JSON object")

    q = sub.add_parser("compare", parents=[common], help="the three laws at one excitation: table and plot",
                       description="Run passive, hysteresis-optimal and Lyapunov with the same sine excitation "
                                   "(--amp [N] at --freq [Hz] or at the passive resonance of --mode, --duration [s]); "
                                   "print the acceleration amplitude at "
                                   "x = 0.45 m [m/s^2], its reduction against passive [%], mean F_N1 [N] and "
                                   "actuator energy [J]; optionally plot displacement and F_N1 (PNG).")
    fm = q.add_mutually_exclusive_group()
    fm.add_argument("--freq", type=float, metavar="HZ", help="excitation frequency [Hz]")
    fm.add_argument("--mode", type=int, metavar="M", default=3,
                    help="excite at the passive resonance of mode M at --amp, found by a short passive step-sine "
                         "as reproduce --quick finds its peaks (~1-2 s; compare.passive_peak_hz; default 3)")
    q.add_argument("--amp", type=float, default=5.0, metavar="N", help="force amplitude [N] (default 5)")
    q.add_argument("--duration", type=float, default=1.0, metavar="S", help="simulated time per law [s] (1)")
    q.add_argument("--plot", metavar="FILE", help="write the time histories here (PNG)")
    add_force(q)
    q.add_argument("--json", action="store_true", help="the table as JSON")

    g = sub.add_parser("budget", parents=[common], help="per-component tick times [us] against the 47.6 us budget",
                       description="Run the loop offline (timed per component) and paced; print median, p99, "
                                   "p99.9 and max [us] per component and for the whole tick, and the paced run's "
                                   "missed periods, lateness [us] and drift [us], next to what the machine allows "
                                   "at the same period, priority and core: the null loop (the same pacing, an "
                                   "empty tick) and, when installed, cyclictest (rt-tests). With --rt-priority N "
                                   "--cpu K the loop thread alone runs at SCHED_FIFO N on core K "
                                   "(docs/loop.md, 'Real-time set-up').")
    g.add_argument("--ticks", type=int, default=105000, metavar="N", help="offline ticks (default 105000 = 5 s)")
    g.add_argument("--paced-s", type=float, default=5.0, metavar="S", help="paced run length [s] (default 5)")
    g.add_argument("--law", choices=["passive", "hysteresis", "lyapunov"], default="lyapunov")
    add_realtime(g)
    g.add_argument("--no-floor", action="store_true", help="leave out the null loop and cyclictest")
    g.add_argument("--json", action="store_true", help="one JSON object instead of a table")

    o = sub.add_parser("observer", parents=[common], help="observer design: kept modes, Kalman gain, eigenvalues",
                       description="Design the nonlinear observer from the configuration (docs/observer.md): the "
                                   "simplified linear model (damper tied at the normal screw, normal springs "
                                   "around the adaptive screw), its kept modes [Hz], the Kalman gain (dlqe on the "
                                   "exact ZOH discretisation), and the largest eigenvalue modulus of the discrete "
                                   "observer, without friction and linearised with it at F_max (implicit, as run, "
                                   "and explicit, to show why it is implicit).")
    o.add_argument("--json", action="store_true", help="one JSON object instead of a table")

    r = sub.add_parser("replay", parents=[common], help="feed a run log's sensor stream through the controller",
                       description="HIL-style replay of an MCAP run log: the recorded sensor readings (and, for "
                                   "the oracle estimator, the recorded plant u_rel, v_rel), tick by tick, through "
                                   "estimator, law, prefilter and force tracking with the configuration stored in "
                                   "the file; every commanded signal is compared with the recorded one. Exit 1 "
                                   "if they differ. A file with only /sensors (a measurement) is replayed without "
                                   "comparison (the configuration of --config/--set applies if it stores none). "
                                   "--set overrides apply to the stored configuration. --plant: instead, the "
                                   "recorded V_cmd [V] and F_exc [N] drive actuator and plant open-loop and "
                                   "every /actuator and /plant signal is compared (docs/data-format.md).")
    r.add_argument("log", metavar="RUN.mcap", help="the log (frictionrt simulate --out)")
    r.add_argument("--paced", action="store_true", help="pace the ticks to the wall clock (21 kHz)")
    add_realtime(r)
    r.add_argument("--plant", action="store_true", help="replay the recorded V_cmd [V] and F_exc [N] into actuator "
                   "and plant and compare their outputs (open-loop check; e.g. with --set plant.interface.mu=0.3)")
    cli_export_c.add_replay_options(r)
    r.add_argument("--json", action="store_true", help="one JSON object instead of text")

    b = sub.add_parser("bench", parents=[common], help="step-time benchmarks [us]",
                       description="Per-step wall time [us] of the compiled kernels: median, p99, p99.9, max.")
    b.add_argument("target", choices=["plant", "loop", "controller"],
                   help="plant: the Newmark/Newton step for 5, 9, 17, 33 pairs; loop: the whole tick and its controller "
                        "part against python-control's nlsys; controller: the whole controller, numba and C (--c DIR)")
    b.add_argument("--steps", type=int, default=21000, metavar="N", help="steps per case (default 21000 = 1 s)")
    b.add_argument("--pairs", type=int, nargs="+", default=[5, 9, 17, 33], metavar="P",
                   help="contact pair counts (default 5 9 17 33)")
    cli_export_c.add_bench_options(b)
    b.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    add_frf_parser(sub, parents=[common])
    add_validate_parser(sub, parents=[common])
    add_reproduce_parser(sub, parents=[common])
    add_tune_parser(sub, parents=[common])
    cli_rig.add_parser(sub, parents=[common])
    cli_diagnose.add_parser(sub, parents=[common])
    add_log_parsers(sub, parents=[common])
    cli_export_c.add_parser(sub, parents=[common])   # export-c, and simulate's --controller
    return ap


def _cmd_config(cfg, args) -> int:
    print(json.dumps(to_dict(cfg), indent=2) if args.json else dumps(cfg), end="" if not args.json else "\n")
    return 0


def _cmd_modes(cfg, args) -> int:
    from plant.modes import format_summary, modes_summary
    s = modes_summary(cfg)
    print(json.dumps(s) if args.json else format_summary(s))
    return 0


def _cmd_impulse(cfg, args) -> int:
    from plant.impulse import impulse_test, plot_frf
    from plant.model import build_plant
    screw = adaptive_screw(cfg)
    if screw is None and args.fn1 is not None:
        return fail(f"--fn1 {args.fn1:g} N: this structure has no adaptive screw (no plant.screws entry with "
                    "adaptive = true) to set; drop --fn1")
    fn1 = (0.0 if screw is None else screw.F_N) if args.fn1 is None else args.fn1
    t = cfg.tracking
    if screw is not None and not (t.F_min_N <= fn1 <= t.F_max_N):
        return fail(f"--fn1 {fn1:g} N lies outside [F_min, F_max] = [{t.F_min_N:g}, {t.F_max_N:g}] N")
    if args.plot:
        out = Path(args.plot)
        if out.suffix.lower() != ".png":
            return fail(f"--plot {out}: the plot is written as PNG; give a file name ending in .png")
        if not out.parent.exists():
            return fail(f"--plot {out}: folder {out.parent} does not exist")
        if msg := refuse_existing([out], args.force, "--plot"):
            return fail(msg)
    res = impulse_test(build_plant(cfg), fn1)
    if args.plot:
        tmp = out.with_suffix(".tmp.png")
        plot_frf(res, str(tmp), cfg.impulse.f_max_hz)
        tmp.replace(out)  # never leave a half-written plot
    if args.json:
        print(json.dumps(res.to_json()))
        return 0
    print(f"impulse test, {'no adaptive screw' if screw is None else f'F_N1 = {fn1:g} N'}, "
          f"hammer {cfg.impulse.peak_N:g} N / {1e3 * cfg.impulse.duration_s:g} ms")
    print(f"{'mode':>4} {'f [Hz]':>9} {'zeta [%]':>9}")
    for mode, f, z in zip(res.modes, res.freq_hz, res.damping_ratio):
        print(f"{mode:>4} {f:>9.2f} {100 * z:>9.3f}")
    if args.plot:
        print(f"plot: {args.plot}")
    return 0


def _cmd_bench(cfg, args) -> int:
    from rt.loop.bench import bench_loop, bench_plant, format_loop, format_table
    if args.target == "controller":
        return cli_export_c.cmd_bench_controller(cfg, args)
    if args.target == "loop":
        if args.steps < 1000:
            return fail(f"--steps {args.steps}: need at least 1000 steps")
        res = bench_loop(cfg, n_steps=args.steps)
        print(json.dumps(res) if args.json else format_loop(res))
        return 0
    if args.steps < 100:
        return fail(f"--steps {args.steps}: need at least 100 steps for percentiles")
    if any(p < 2 for p in args.pairs):
        return fail(f"--pairs {args.pairs}: every pair count must be >= 2")
    if not cfg.plant.interface.enabled:
        return fail("bench plant: times the contact step at several pair counts; this structure has no interface "
                    "(plant.interface.enabled = false)")
    res = bench_plant(cfg, args.pairs, args.steps, progress=not args.json)
    print(json.dumps(res) if args.json else format_table(res))
    return 0


def _cmd_simulate(cfg, args) -> int:
    from tqdm import tqdm

    from rt.log.data_format import run_test_record
    from rt.loop.faults import schedule, to_json
    from rt.log.design_record import DESIGN_ATTACHMENT, MEDIA_TYPE, design_arrays, to_npz
    from rt.loop import build_loop, check_run_input, initial_loop_state, run, summary
    from rt.log.writer import INTERRUPT_DRAIN_S, open_run_log, run_metadata
    if args.seed is not None and args.seed < 0:
        return fail(f"--seed {args.seed}: must be a non-negative integer")
    if msg := unpaced_realtime(args):
        return fail(msg)
    if not args.ring > 0:
        return fail(f"--ring {args.ring:g} s: must be > 0 s")
    base = None
    if args.out:
        base = Path(args.out)
        if base.suffix in (".mcap", ".rrd"):
            base = base.with_suffix("")
        if not base.parent.exists():
            return fail(f"--out {args.out}: folder {base.parent} does not exist")
        outputs = [base.with_name(base.name + s) for s in (".mcap", ".foxglove.json", *(() if args.no_rrd else (".rrd",)))]
        if msg := refuse_existing(outputs, args.force):
            return fail(msg)
    writer = None
    try:
        faults = schedule(args.fault, cfg)
        if not args.paced and any("cpu_stall" in f for f in args.fault):
            return fail("--fault cpu_stall: a CPU stall is seen as overruns of the paced loop only; add --paced")
        loop = build_loop(cfg, args.law, args.estimator)
        n = check_run_input(loop, args.freq, args.amp, args.duration, ring=base is not None)  # --out: a ring
        late = [t for t, f in zip(args.fault, faults) if f[2] >= n]
        if late:
            return fail(f"--fault {late[0]!r}: starts after the run's end ({args.duration:g} s); give a TIME below it")
        if base is not None:
            seed = cfg.rt.seed if args.seed is None else args.seed
            meta = run_metadata(cfg, loop.law, loop.estimator, seed, args.freq, args.amp, args.duration, args.paced)
            meta["faults"] = json.dumps(to_json(faults))
            meta["controller_design"] = cli_export_c.design_hash_of(loop, seed)   # what export-c writes for it
            writer = open_run_log(base, loop.signals, 1.0 / cfg.dt_s, meta, rrd=not args.no_rrd, ring_s=args.ring)
            writer.mcap.add_metadata("test", run_test_record(loop, args.freq, args.amp, args.duration))
            writer.mcap.add_attachment(DESIGN_ATTACHMENT, MEDIA_TYPE,
                                       to_npz(design_arrays(loop, initial_loop_state(loop, seed))))
        with tqdm(total=n, unit="tick", unit_scale=True, disable=args.json, desc=f"simulate {loop.law}") as bar:
            r = run(loop, args.freq, args.amp, args.duration, paced=args.paced, seed=args.seed, progress=bar.update,
                    writer=writer, faults=faults, controller=cli_export_c.controller_of(args, loop))
    except ValueError as exc:
        return fail(str(exc))
    finally:
        if writer is not None:
            writer.finish()  # idempotent: closes the files also if the run never started
    if len(r.log) < 2:
        return fail("interrupted before the loop ran: nothing to summarise")
    s = summary(r)
    s["interrupted"] = r.interrupted or (writer is not None and writer.interrupted)
    realtime_notes(s.get("realtime"))
    if writer is not None:
        s |= {"mcap": writer.paths["mcap"], "rrd": writer.paths["rrd"], "foxglove_layout": writer.paths["foxglove"],
              "dropped_blocks": writer.dropped_blocks,
              "unwritten_ticks": writer.unwritten_ticks}
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
              f"u_rel {s['u_rel_nrmse']:.3f}; RT1 amplitude u0 error {100 * s['u0_rel_error']:+.1f} %")
    for f in s["faults"]:
        print(f"fault {f['kind']}{'/' + f['sensor'] if f['sensor'] else ''} at tick {f['tick']}: "
              + (f"{f['name']} (code {f['code']}) detected at tick {f['detected_tick']}, passive at tick "
                 f"{f['passive_tick']}" if f["detected_tick"] is not None else "not detected"))
    if s["trips"] and not s["faults"]:
        print("supervisor: " + ", ".join(f"{t['name']} (code {t['code']}) at tick {t['tick']}" for t in s["trips"]))
    if writer is not None:
        print(f"log: {s['mcap']}{', ' + s['rrd'] if s['rrd'] else ''}; dropped blocks {s['dropped_blocks']}; "
              f"Foxglove layout {s['foxglove_layout']}")
    return 130 if s["interrupted"] else 0


def _cmd_replay(cfg, args) -> int:
    from rt.log.design_record import describe
    from rt.loop.replay import replay
    if args.c is not None:
        return cli_export_c.cmd_replay_c(cfg, args)
    if args.plant:
        return cmd_replay_plant(cfg, args)
    if msg := unpaced_realtime(args):
        return fail(msg)
    try:
        res = replay(args.log, paced=args.paced, fallback_cfg=cfg, sets=args.sets)
    except ValueError as exc:
        return fail(str(exc))
    realtime_notes(res.get("realtime"))
    code = 1 if res["bit_exact"] is False else (130 if res["interrupted"] else 0)
    if args.json:
        print(json.dumps(res))
        return code
    print(f"replay {res['file']}: law {res['law']}, estimator {res['estimator']}, {res['ticks']} ticks"
          f"{' (paced, ' + str(res['overruns']) + ' overruns)' if res['paced'] else ''}, "
          f"{res['realtime_factor']:.1f}x real time{', interrupted' if res['interrupted'] else ''}")
    if res["missing_ticks"]:
        print(f"  the log misses {res['missing_ticks']} ticks (dropped blocks): the states differ after a gap")
    print(describe(res["design"]))
    if res["bit_exact"] is None:
        print("  no recorded controller outputs: nothing to compare; replayed outputs (min / mean / max):")
        for name, o in res["outputs"].items():
            print(f"  {name:>15} {o['min']:>12.5g} {o['mean']:>12.5g} {o['max']:>12.5g}")
    else:
        print(f"  {'bit-exact' if res['bit_exact'] else 'DIFFERS'}: max |diff| {res['max_abs_diff']:.3g} over "
              f"{', '.join(res['signals_compared'])}")
        if not res["bit_exact"]:
            worst = ", ".join(f"{k} {v:.3g}" for k, v in res["max_abs_diff_by_signal"].items() if v)
            print(f"  first mismatch at tick {res['first_mismatch_tick']}; max |diff| per signal: {worst}")
    return code


def _cmd_compare(cfg, args) -> int:
    from tqdm import tqdm

    from rt.experiments.compare import compare, plot, table
    from rt.loop import build_loop, check_run_input
    if args.plot:
        out = Path(args.plot)
        if out.suffix.lower() != ".png" or not out.parent.exists():
            return fail(f"--plot {out}: give a .png file in an existing folder")
        if msg := refuse_existing([out], args.force, "--plot"):
            return fail(msg)
    if args.freq is None and not 1 <= args.mode <= 9:
        return fail(f"--mode {args.mode}: give a bending mode 1..9")
    if not args.amp > 0:   # the table is relative to the passive response, which 0 N leaves at 0
        return fail(f"--amp {args.amp:g} N: compare needs a finite force > 0 N, e.g. --amp 5")
    try:
        passive = build_loop(cfg, "passive")
        if args.freq is None:
            from rt.experiments.compare import passive_peak_hz
            check_run_input(passive, 1.0, args.amp, args.duration)  # amplitude and duration before the search
            with tqdm(unit="point", disable=args.json, desc=f"passive peak of mode {args.mode}") as bar:
                args.freq = round(passive_peak_hz(passive, args.mode, args.amp, progress=bar.update), 2)
        n = check_run_input(passive, args.freq, args.amp, args.duration)
        with tqdm(total=3 * n, unit="tick", unit_scale=True, disable=args.json, desc="compare") as bar:
            runs = compare(cfg, args.freq, args.amp, args.duration, progress=bar.update)
    except ValueError as exc:
        return fail(str(exc))
    rows = table(runs)
    if args.plot:
        tmp = out.with_suffix(".tmp.png")
        plot(runs, str(tmp))
        tmp.replace(out)
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{args.amp:g} N at {args.freq:g} Hz, {args.duration:g} s per law, oracle estimator")
    print(f"{'law':>11} {'acc 0.45 m [m/s^2]':>19} {'vs passive':>11} {'mean F_N1 [N]':>14} {'energy [J]':>11}")
    for r in rows:
        print(f"{r['law']:>11} {r['acc045_amplitude']:>19.4f} {-r['reduction_pct']:>+10.1f}% "
              f"{r['fn1_mean_n']:>14.1f} {r['actuator_energy_j']:>11.3g}")
    if args.plot:
        print(f"plot: {args.plot}")
    return 0


def _cmd_observer(cfg, args) -> int:
    from observer.kalman import design_observer
    try:
        d = design_observer(cfg).summary(cfg.tracking.F_max_N)
    except ValueError as exc:
        return fail(str(exc))
    if args.json:
        print(json.dumps(d))
        return 0
    print(f"observer: {d['n_states']} states, modes [Hz]: {', '.join(f'{f:.1f}' for f in d['modes_hz'])}")
    print(f"  tied at x = {d['x_tied_m']} m, normal springs at x = {d['x_springs_m']} m, zeta {d['zeta']:g}, "
          f"static correction D_u {d['D_u_m_per_n']:.3e} m/N")
    print(f"  Kalman (dlqe): Q = diag{tuple(d['Q_n2'])} N^2, R = {d['R_m2_s2']:.3g} (m/s)^2; "
          f"|M| {d['gain_norm_filter']:.3g}, |L| {d['gain_norm_predictor']:.3g}")
    print(f"  max |eig| discrete: {d['max_abs_eig_discrete']:.7f} (no friction), "
          f"{d['max_abs_eig_discrete_friction_fmax']:.7f} (friction at F_max = {d['F_max_n']:g} N, implicit), "
          f"{d['max_abs_eig_discrete_friction_fmax_explicit']:.4f} (explicit ZOH would be)")
    return 0


def _cmd_budget(cfg, args) -> int:
    from rt.loop.budget import budget, format_budget
    if args.ticks < 1000 or args.paced_s <= 0:
        return fail(f"--ticks {args.ticks} / --paced-s {args.paced_s}: need >= 1000 ticks and a positive paced time")
    try:
        res = budget(cfg, args.law, args.ticks, args.paced_s, floor=not args.no_floor)
    except ValueError as exc:
        return fail(str(exc))
    realtime_notes(res["paced"]["realtime"])
    print(json.dumps(res) if args.json else format_budget(res))
    return 0


COMMANDS = {"config": _cmd_config, "modes": _cmd_modes, "impulse": _cmd_impulse, "simulate": _cmd_simulate,
            "replay": _cmd_replay, "validate": cmd_validate,
            "compare": _cmd_compare, "budget": _cmd_budget, "bench": _cmd_bench,
            "observer": _cmd_observer, "frf": cmd_frf, "tune": cmd_tune,
            "recover": cmd_recover, "inspect": cmd_inspect, "reproduce": cmd_reproduce,
            "rig": cli_rig.cmd_rig, "diagnose": cli_diagnose.cmd_diagnose, "export-c": cli_export_c.cmd_export_c}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    json_errors("--json" in argv)   # for this command line only (rt.cli.common)
    try:
        return _main(build_parser().parse_args(argv))
    finally:
        json_errors(False)


def _main(args) -> int:
    try:
        args.sets = [*args.sets, *realtime_sets(args)]  # --rt-priority, --cpu (replay: onto the stored configuration)
        cfg = load(args.config, args.sets)
        if verb := actuator_verb(args):
            require_adaptive_screw(cfg, verb)   # one line instead of a failure deep in the loop's design
    except ConfigError as exc:
        return fail(str(exc))
    try:
        return COMMANDS[args.command](cfg, args)
    except RuntimeError as exc:  # a run that failed numerically: say so, no traceback
        print(f"frictionrt: {args.command} failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl-C outside a loop (which absorbs it); writers closed their files
        print(f"frictionrt: {args.command} interrupted (Ctrl-C)", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
