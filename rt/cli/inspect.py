"""``frictionrt inspect``: a log or measurement as an .rrd recording for rerun (rt.log.rrd_log).

``add_parser(subparsers, parents)`` registers the subcommand, ``cmd_inspect(cfg, args)`` runs it and
returns the exit code (0 done, 2 bad input with one line on stderr naming the file, the problem and the fix).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import shtab

from frictionrt.rt.cli.common import add_deprecated, add_force, add_out, fail

INSPECT = """Convert an MCAP run log or measurement (an MCAP file with some of the topics /rt, /sensors,
/observer, /tracking, /actuator, /plant and the "signals" record, e.g. /sensors only) to a rerun
.rrd recording with the default blueprint of `simulate --out`: F_N1 setpoint vs measured, the
friction hysteresis (if /plant is present) and one time-series tab per topic present, and beside
it, as `simulate --out` does, the Foxglove layout of the same panels (NAME.foxglove.json for
NAME.rrd). Times are the log times (t = k / rate_hz [s]), ticks k and the file's UTC time."""

INSPECT_EXAMPLES = """examples:
  frictionrt inspect logs/run.mcap               # writes logs/run.rrd; then: rerun logs/run.rrd
  frictionrt inspect meas/impulse.mcap -o /tmp/impulse.rrd --force --json"""

TRUNCATED_HINT = "; `frictionrt recover FILE -o FIXED.mcap` salvages its complete chunks"


def add_parser(subparsers, parents) -> argparse.ArgumentParser:
    """Register ``inspect`` (parents: frictionrt's --config/--set parser)."""
    i = subparsers.add_parser("inspect", parents=parents, help="an MCAP log or measurement as .rrd for rerun",
                              description=INSPECT, epilog=INSPECT_EXAMPLES)
    i.add_argument("log", metavar="RUN.mcap", help="the MCAP log or measurement").complete = shtab.FILE
    add_out(i, "OUT.rrd", "the file to write the recording to, with its Foxglove layout OUT.foxglove.json beside "
                          "it (default: RUN.rrd next to the input)")
    add_deprecated(i, "--output", "-o/--out")
    add_force(i)
    i.add_argument("--json", action="store_true",
                   help="one JSON object: input, output, foxglove_layout, ticks, first_tick, last_tick, topics, "
                        "entities, seconds")
    return i


def cmd_inspect(cfg, args) -> int:
    from frictionrt.rt.log.rrd_log import mcap_to_rrd
    src = Path(args.log)
    dst = Path(args.out) if args.out else src.with_suffix(".rrd")
    if dst.suffix != ".rrd":
        return fail(f"-o {dst}: rerun opens .rrd files; give a name ending in .rrd")
    t0 = time.perf_counter()
    try:
        r = mcap_to_rrd(src, dst, overwrite=args.force)
    except ValueError as exc:
        msg = str(exc)
        return fail(msg + (TRUNCATED_HINT.replace("FILE", str(src)) if "truncated MCAP file" in msg else ""))
    r["seconds"] = time.perf_counter() - t0
    if args.json:
        print(json.dumps(r))
        return 0
    span = "" if not r["ticks"] else f" (k = {r['first_tick']}..{r['last_tick']})"
    print(f"{r['output']}: {r['ticks']} ticks{span} of {', '.join(r['topics']) or 'no topic'}, "
          f"{len(r['entities'])} entities, in {r['seconds']:.1f} s; open it with: rerun {r['output']}")
    print(f"Foxglove layout: {r['foxglove_layout']} (Layouts > Import from file, with {args.log} open)")
    return 0
