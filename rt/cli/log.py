"""``frictionrt recover`` and ``frictionrt inspect``: salvaging a killed run's log, and viewing a
log or measurement in rerun.

``add_parsers(subparsers, parents)`` registers both subcommands; ``cmd_recover(cfg, args)`` and
``cmd_inspect(cfg, args)`` run them and return the exit code (0 done, 2 bad input with one line
on stderr naming the file, the problem and the fix).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from rt.cli.common import add_force, fail

RECOVER = """Recover a run log whose writer was killed (kill -9, power loss): `frictionrt simulate --out
NAME` leaves NAME.mcap.part. Every complete chunk (each CRC-checked) is written to a new, finished
and indexed MCAP file with the same schemas, channels and metadata records ("frictionrt":
configuration, versions, seed, command line; "signals") plus a "frictionrt.recover" record;
`frictionrt replay` and `frictionrt inspect` read it. Lost: the chunk the writer had open in memory
(less than one chunk: chunk_ticks = 1045 ticks = 49.8 ms at 21 kHz for simulate's 90 signals) and the ticks it had
not taken from the loop yet; a chunk cut short on disk is reported. An existing output is replaced only with
--force (never the input)."""

RECOVER_EXAMPLES = """examples:
  frictionrt recover logs/run.mcap.part -o logs/run.mcap
  frictionrt recover logs/run.mcap.part -o logs/run_fixed.mcap --json
  frictionrt inspect logs/run.mcap          # then: the .rrd for rerun"""

INSPECT = """Convert an MCAP run log or measurement (an MCAP file with some of the topics /rt, /sensors,
/observer, /tracking, /actuator, /plant and the "signals" record, e.g. /sensors only) to a rerun
.rrd recording with the default blueprint of `simulate --out`: F_N1 setpoint vs measured, the
friction hysteresis (if /plant is present) and one time-series tab per topic present. Times are the
log times (t = k / rate_hz [s]) and ticks k."""

INSPECT_EXAMPLES = """examples:
  frictionrt inspect logs/run.mcap               # writes logs/run.rrd; then: rerun logs/run.rrd
  frictionrt inspect meas/impulse.mcap -o /tmp/impulse.rrd --force --json"""

TRUNCATED_HINT = "; `frictionrt recover FILE -o FIXED.mcap` salvages its complete chunks"


def add_parsers(subparsers, parents) -> None:
    """Register ``recover`` and ``inspect`` (parents: frictionrt's --config/--set parser)."""
    fmt = argparse.RawDescriptionHelpFormatter
    r = subparsers.add_parser("recover", parents=parents, help="salvage a killed run's log (NAME.mcap.part)",
                              description=RECOVER, epilog=RECOVER_EXAMPLES, formatter_class=fmt)
    r.add_argument("src", metavar="BROKEN.mcap", help="the unfinished log, e.g. logs/run.mcap.part")
    r.add_argument("-o", "--out", "--output", required=True, metavar="FIXED.mcap", dest="out",
                   help="the recovered log to write (its folder must exist; never the input)")
    add_force(r)
    r.add_argument("--json", action="store_true",
                   help="one JSON object: input, output, ticks, first_tick, last_tick, missing_ticks, chunks, "
                        "chunk_ticks, finished, lost_bytes, lost_record, lost_chunk_ticks, stop, metadata, seconds")
    i = subparsers.add_parser("inspect", parents=parents, help="an MCAP log or measurement as .rrd for rerun",
                              description=INSPECT, epilog=INSPECT_EXAMPLES, formatter_class=fmt)
    i.add_argument("log", metavar="RUN.mcap", help="the MCAP log or measurement")
    i.add_argument("-o", "--out", "--output", metavar="OUT.rrd", dest="out",
                   help="the recording (default: RUN.rrd next to the input)")
    add_force(i)
    i.add_argument("--json", action="store_true",
                   help="one JSON object: input, output, ticks, first_tick, last_tick, topics, entities, seconds")


def cmd_recover(cfg, args) -> int:
    from rt.log.recover import recover
    try:
        r = recover(args.src, args.out, overwrite=args.force)
    except ValueError as exc:
        return fail(str(exc))
    if args.json:
        print(json.dumps(r))
        return 0
    print(f"recovered {r['ticks']} ticks (k = {r['first_tick']}..{r['last_tick']}"
          f"{', ' + str(r['missing_ticks']) + ' missing inside' if r['missing_ticks'] else ''}) from {r['chunks']} "
          f"complete chunks of {r['input']} into {r['output']} in {r['seconds']:.1f} s")
    if r["finished"]:
        print("  the input was a finished file: nothing lost")
        return 0
    cut = "nothing on disk"
    if r["lost_bytes"]:
        ticks = r["lost_chunk_ticks"]
        cut = (f"{r['lost_bytes']} B of a {r['lost_record']} record cut short"
               + (f" (ticks {ticks[0]}..{ticks[1]})" if ticks else ""))
    print(f"  lost: {cut}; the chunk open in memory (at most {r['chunk_ticks']} ticks) and the rows not yet "
          "taken by the writer")
    return 0


def cmd_inspect(cfg, args) -> int:
    from rt.log.rrd_log import mcap_to_rrd
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
    return 0
