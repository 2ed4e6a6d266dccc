"""``frictionrt validate FILE.mcap``: check a run log or measurement against the measurement
format (rt/log/data_format.py, docs/data-format.md).

``add_parser(subparsers)`` registers the subcommand, ``cmd_validate(cfg, args)`` runs it: exit 0
valid, 1 invalid (the problems listed), 2 unreadable file (one line on stderr).
"""
from __future__ import annotations

import argparse
import json

import shtab

from frictionrt.rt.cli.common import fail

DESCRIPTION = """Check an MCAP run log or measurement against the measurement format (docs/data-format.md):
the metadata records "signals" (layout, rate [Hz]), "test" (kind, excitation point x [m], sensor positions
[m], law and gains, excitation amplitude [N] and frequencies [Hz]) and, for simulation logs, "frictionrt";
the required topics and fields (F_exc [N], accelerations [m/s^2], bolt forces [N], piezo voltage [V] and
current [A], setpoints [N] and V_cmd [V] with a law) with their units and float64 type; message times on the
tick grid (log_time = (k 10^9) // rate_hz ns), increasing, without duplicates; no NaN samples. Every problem
names the topic, field or metadata entry. Exit 0 valid, 1 invalid, 2 unreadable file."""

EXAMPLES = """examples:
  frictionrt validate logs/lyap.mcap
  frictionrt validate measurements/impulse_100N.mcap --json"""


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    """Register ``validate`` on an argparse subparsers object (parents: frictionrt's --config/--set
    parser; the configuration plays no part in the check)."""
    p = subparsers.add_parser("validate", parents=parents or [], help="check a log or measurement against the "
                              "documented measurement format", description=DESCRIPTION, epilog=EXAMPLES)
    p.add_argument("file", metavar="FILE.mcap", help="the MCAP file to check").complete = shtab.FILE
    p.add_argument("--json", action="store_true", help='one JSON object: {"file", "valid", "problems": '
                   '[{"where", "kind", "detail"}]}')
    return p


def cmd_validate(cfg, args) -> int:
    from frictionrt.rt.log.data_format import validate
    try:
        problems = validate(args.file)
    except ValueError as exc:
        return fail(f"{exc} (validate reads MCAP files; a file cut short by a crash: frictionrt recover)")
    if args.json:
        print(json.dumps({"file": str(args.file), "valid": not problems, "problems": [p.to_dict() for p in problems]}))
    elif problems:
        print(f"{args.file}: INVALID, {len(problems)} problem{'s' if len(problems) > 1 else ''}:")
        for p in problems:
            print(f"  {p}")
    else:
        print(f"{args.file}: valid")
    return 1 if problems else 0
