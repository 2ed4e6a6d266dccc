"""``frictionrt recover``: salvaging a killed run's log (rt.log.recover).

``add_parser(subparsers, parents)`` registers the subcommand, ``cmd_recover(cfg, args)`` runs it and
returns the exit code (0 done, 2 bad input with one line on stderr naming the file, the problem and the fix).
"""
from __future__ import annotations

import argparse
import json

import shtab

from frictionrt.rt.cli.common import add_deprecated, add_force, add_out, fail

RECOVER = """Recover a run log whose writer was killed (kill -9, power loss): `frictionrt simulate --out
NAME` leaves NAME.mcap.part. Every complete chunk (each CRC-checked) is written to a new, finished
and indexed MCAP file with the same schemas, channels and metadata records ("frictionrt":
configuration, versions, seed, command line; "signals") plus a "frictionrt.recover" record;
`frictionrt replay` and `frictionrt inspect` read it. Lost: the chunk the writer had open in memory
(less than one chunk: chunk_ticks = 722 ticks = 34.4 ms at 21 kHz for simulate's 146 signals) and the ticks it had
not taken from the loop yet; a chunk cut short on disk is reported. An existing output is replaced only with
--force (never the input)."""

RECOVER_EXAMPLES = """examples:
  frictionrt recover logs/run.mcap.part -o logs/run.mcap
  frictionrt recover logs/run.mcap.part -o logs/run_fixed.mcap --json
  frictionrt inspect logs/run.mcap          # then: the .rrd for rerun"""


def add_parser(subparsers, parents) -> argparse.ArgumentParser:
    """Register ``recover`` (parents: frictionrt's --config/--set parser)."""
    r = subparsers.add_parser("recover", parents=parents, help="salvage a killed run's log (NAME.mcap.part)",
                              description=RECOVER, epilog=RECOVER_EXAMPLES)
    r.add_argument("src", metavar="BROKEN.mcap", help="the unfinished log, e.g. logs/run.mcap.part").complete = shtab.FILE
    add_out(r, "FIXED.mcap", "the file to write the recovered log to (required; its folder must exist; never the "
                             "input)")
    add_deprecated(r, "--output", "-o/--out")
    add_force(r)
    r.add_argument("--json", action="store_true",
                   help="one JSON object: input, output, ticks, first_tick, last_tick, missing_ticks, chunks, "
                        "chunk_ticks, finished, lost_bytes, lost_record, lost_chunk_ticks, stop, metadata, seconds")
    return r


def cmd_recover(cfg, args) -> int:
    from frictionrt.rt.log.recover import recover
    if not args.out:   # not required by argparse: the old spelling --output gives it too
        return fail("recover: give -o FIXED.mcap, the file to write the recovered log to")
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
