"""``frictionrt replay``: a run log through the controller (rt.loop.replay), with --c DIR through the C export
of it (rt.export.replay_c, docs/export-c.md), or with --plant its V_cmd and F_exc through actuator and plant
(rt.loop.replay_plant); the recorded signals compared."""
from __future__ import annotations

import argparse
import json
import sys

import shtab

from frictionrt.rt.cli.common import add_realtime, fail, realtime_notes, unpaced_realtime
from frictionrt.rt.loop.coverage import coverage_problem, format_coverage

GAP = " (dropped blocks, or lost in a crash)"   # a log's missing ticks, to a replay


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``replay`` (parents: frictionrt's --config/--set parser)."""
    r = sub.add_parser("replay", parents=parents, help="feed a run log's sensor stream through the controller",
                       description="HIL-style replay of an MCAP run log: the recorded sensor readings (and, for "
                                   "the oracle estimator, the recorded plant u_rel, v_rel), tick by tick, through "
                                   "estimator, law, prefilter and force tracking with the configuration stored in "
                                   "the file; every commanded signal is compared with the recorded one. Exit 1 "
                                   "if they differ. A file with only /sensors (a measurement) is replayed without "
                                   "comparison (the configuration of --config/--set applies if it stores none). "
                                   "--set overrides apply to the stored configuration. --plant: instead, the "
                                   "recorded V_cmd [V] and F_exc [N] drive actuator and plant open-loop and "
                                   "every /actuator and /plant signal is compared (docs/data-format.md).")
    r.add_argument("log", metavar="RUN.mcap", help="the log (frictionrt simulate --out)").complete = shtab.FILE
    r.add_argument("--paced", action="store_true", help="pace the ticks to the wall clock (21 kHz)")
    add_realtime(r)
    r.add_argument("--plant", action="store_true", help="replay the recorded V_cmd [V] and F_exc [N] into actuator "
                   "and plant and compare their outputs (open-loop check; e.g. with --set plant.interface.mu=0.3)")
    r.add_argument("--c", metavar="DIR", default=None, help="replay through the C export in DIR (frictionrt "
                   "export-c) instead of the numba controller, compared bit for bit with the log "
                   "(docs/export-c.md)").complete = shtab.DIRECTORY
    r.add_argument("--cc", metavar="CC", default=None, help="with --c: the C compiler (default: $CC or cc)")
    r.add_argument("--c-opt", metavar="FLAG", default="-O2", help="with --c: the optimisation flag, written "
                   "--c-opt=-O0")
    r.add_argument("--require-coverage", action="store_true",
                   help="exit 1 when the controlled law (hysteresis, Lyapunov) never left F_min in the log: "
                        "a bit-exact replay of such a log does not test the law")
    r.add_argument("--json", action="store_true", help="one JSON object instead of text")
    return r


def cmd_replay(cfg, args) -> int:
    """``replay``: the log through the numba controller, with --c DIR through the C export, with
    --plant its V_cmd and F_exc through actuator and plant; exit 0 when bit-exact (or nothing to
    compare), 1 when a signal differs, 130 after a Ctrl-C, 2 for bad input."""
    replay, show = (_replay_c, _show_c) if args.c is not None else \
        (_replay_plant, _show_plant) if args.plant else (_replay, _show)
    try:
        res = replay(cfg, args)
    except ValueError as exc:
        return fail(str(exc))
    realtime_notes(res.get("realtime"))
    code = 1 if res["bit_exact"] is False or res.get("within_bound") is False else \
        (130 if res.get("interrupted") else 0)
    problem = coverage_problem(res["coverage"]) if args.require_coverage and "coverage" in res else None
    if problem and code == 0:
        code = 1
    if args.json:
        print(json.dumps(res))
    else:
        show(res)
        if "coverage" in res:
            print(format_coverage(res["coverage"]))
    if problem:
        print(problem, file=sys.stderr)
    return code


def _replay(cfg, args) -> dict:
    from frictionrt.rt.loop.replay import replay
    if msg := unpaced_realtime(args):
        raise ValueError(msg)
    return replay(args.log, paced=args.paced, fallback_cfg=cfg, sets=args.sets)


def _show(res) -> None:
    print(f"replay {res['file']}: law {res['law']}, estimator {res['estimator']}, {res['ticks']} ticks"
          f"{' (paced, ' + str(res['overruns']) + ' overruns)' if res['paced'] else ''}, "
          f"{res['realtime_factor']:.1f}x real time{', interrupted' if res['interrupted'] else ''}")
    _print_comparison(res, GAP, "no recorded controller outputs: nothing to compare; replayed outputs", 15,
                      ", ".join(res["signals_compared"]), "max |diff| per signal",
                      [(k, v) for k, v in res["max_abs_diff_by_signal"].items() if v])


def _print_comparison(res, gap: str, unrecorded: str, width: int, over: str, worst_label: str, worst) -> None:
    """What a replay prints after its first line: the log's gap (``gap``), the design it ran; with
    nothing recorded to compare, ``unrecorded`` and the replayed signals' min / mean / max (names
    ``width`` wide); else bit-exact or DIFFERS with the largest difference over ``over`` and, when
    they differ, the first differing tick and ``worst`` ((signal, |diff|) pairs) as ``worst_label``."""
    from frictionrt.rt.log.design_record import describe
    if res["missing_ticks"]:
        print(f"  the log misses {res['missing_ticks']} ticks{gap}")
        _print_ranges(res)
    print(describe(res["design"]))
    if res["bit_exact"] is None:
        print(f"  {unrecorded} (min / mean / max):")
        for name, o in res["outputs"].items():
            print(f"  {name:>{width}} {o['min']:>12.5g} {o['mean']:>12.5g} {o['max']:>12.5g}")
        return
    print(f"  {'bit-exact' if res['bit_exact'] else 'DIFFERS'}: max |diff| {res['max_abs_diff']:.3g} over {over}")
    if not res["bit_exact"]:
        print(f"  first mismatch at tick {res['first_mismatch_tick']}; {worst_label}: "
              + ", ".join(f"{k} {v:.3g}" for k, v in worst))


def _print_ranges(res) -> None:
    """The compared, missing and not compared tick ranges of a replay of a log with gaps."""
    for key, label in (("compared_ranges", "compared"), ("missing_ranges", "missing"),
                       ("not_compared_ranges", "not compared")):
        if res.get(key):
            print(f"  {label}: " + ", ".join(f"{a}..{b}" for a, b in res[key]))
    if res.get("restarted_from"):
        print("  restarted from the key frames of ticks " + ", ".join(map(str, res["restarted_from"])))
    if res.get("restart_note"):
        print(f"  {res['restart_note']}")
    if res.get("after_cold_restart"):
        cold = res["after_cold_restart"]
        print(f"  after a restart with a cold contact-solver cache: {cold['signals_differing']} signals differ "
              f"to round-off (F_N1 {cold['max_abs_diff_by_signal'].get('F_N1', 0.0):.3g} N); key frames with "
              "rt.keyframe_plant_cache = true make it bit-exact")


def _replay_plant(cfg, args) -> dict:
    """``replay --plant``: the log's V_cmd and F_exc into actuator and plant, their outputs compared."""
    from frictionrt.rt.loop.replay_plant import replay_plant
    if args.paced:
        raise ValueError("--plant with --paced: the plant replay runs offline only; drop --paced")
    return replay_plant(args.log, fallback_cfg=cfg, sets=args.sets)


def _show_plant(res) -> None:
    sets = f" with {' '.join(res['sets'])}" if res["sets"] else ""
    print(f"replay --plant {res['file']}{sets}: {res['ticks']} ticks of V_cmd, F_exc into actuator and plant "
          f"({res['wall_s']:.2f} s), failed contact solves {res['failed_solves']}")
    worst = sorted(((v, k) for k, v in res["max_abs_diff_by_signal"].items() if v), reverse=True)[:8]
    _print_comparison(res, GAP, "no recorded /actuator or /plant signals: nothing "
                      "to compare; replayed", 10, f"{len(res['signals_compared'])} /actuator and /plant signals",
                      "largest |diff| (SI units)", [(k, v) for v, k in worst])


def _replay_c(cfg, args) -> dict:
    """``replay --c DIR``: the log through the C export in DIR (rt.export.replay_c)."""
    from frictionrt.rt.export.replay_c import replay_c
    if args.plant or args.paced:
        raise ValueError("--c replays the controller offline: drop --plant / --paced")
    return replay_c(args.log, args.c, cc=args.cc, opt=args.c_opt, fallback_cfg=cfg, sets=args.sets)[0]


def _show_c(res) -> None:
    print(f"replay {res['file']} --c {res['export']}: law {res['law']}, estimator {res['estimator']}, "
          f"{res['ticks']} ticks through the C controller ({res['wall_s'] * 1e3:.1f} ms), design {res['design_hash']}")
    print(f"  build: {res['build']}")
    if res["missing_ticks"]:
        print(f"  the log misses {res['missing_ticks']} ticks{GAP}")
        _print_ranges(res)
    if res.get("precision") == "float32":
        print(f"  float32 export, against its stated bound: {'within' if res['within_bound'] else 'OUTSIDE'}")
        for sig, d in res["equivalence"].items():
            print(f"    {sig:<15} " + (f"max |diff| {d['max_abs']:.3g} (bound {d['bound']:g}), rms {d['rms']:.3g}"
                                      if "max_abs" in d else f"{d['ticks_differ']} ticks differ"))
    elif res["bit_exact"] is None:
        print("  the log records no controller outputs: nothing to compare")
    elif res["bit_exact"]:
        print(f"  bit-exact: {len(res['signals_compared'])} signals x {res['ticks']} ticks "
              f"({', '.join(res['signals_compared'])})")
    else:
        worst = ", ".join(f"{k} {v:.3g}" for k, v in res["max_abs_diff_by_signal"].items() if v)
        print(f"  DIFFERS: first at tick {res['first_mismatch_tick']} in {', '.join(res['first_mismatch_signals'])}; "
              f"max |diff| per signal: {worst}")
