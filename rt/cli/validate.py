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
names the topic, field or metadata entry. A folder of FRF files (or one FRF file, .csv .uff .unv with its
JSON sidecar; docs/data-format.md, "FRF files") is checked as diagnose reads it. Exit 0 valid, 1 invalid,
2 unreadable file."""

EXAMPLES = """examples:
  frictionrt validate logs/lyap.mcap
  frictionrt validate measurements/impulse_100N.mcap --json
  frictionrt validate logs/lab_frf"""


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    """Register ``validate`` on an argparse subparsers object (parents: frictionrt's --config/--set
    parser; the configuration plays no part in the check)."""
    p = subparsers.add_parser("validate", parents=parents or [], help="check a log or measurement against the "
                              "documented measurement format", description=DESCRIPTION, epilog=EXAMPLES)
    p.add_argument("file", metavar="FILE.mcap", help="the MCAP file to check, or a folder of FRF files or one "
                   "of them").complete = shtab.FILE
    p.add_argument("--json", action="store_true", help='one JSON object: {"file", "valid", "problems": '
                   '[{"where", "kind", "detail"}]}')
    return p


def cmd_validate(cfg, args) -> int:
    from pathlib import Path

    from frictionrt.rt.log.data_format import validate
    from frictionrt.rt.log.frf_files import SUFFIXES
    if Path(args.file).is_dir() or Path(args.file).suffix.lower() in SUFFIXES:
        return _validate_frf(args)
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


def _validate_frf(args) -> int:
    """A folder of FRF files or one FRF file, read as diagnose reads it (rt.log.frf_files): valid, or
    invalid with the reader's problem (it stops at the first)."""
    from pathlib import Path

    from frictionrt.rt.log.frf_files import load_frf_folder, read_frf
    path = Path(args.file)
    if not path.exists():
        return fail(f"{path}: no such file or folder")
    try:
        tests = load_frf_folder(path) if path.is_dir() else [read_frf(path)]
        problem = None
    except ValueError as exc:
        tests, problem = [], str(exc)
    if args.json:
        print(json.dumps({"file": str(path), "valid": problem is None, "problems": [] if problem is None else
                          [{"where": str(path), "kind": "frf file", "detail": problem}]}))
    elif problem:
        print(f"{path}: INVALID, 1 problem:\n  {problem}")
    else:
        print(f"{path}: valid ({len(tests)} FRF file{'s' if len(tests) != 1 else ''})")
    return 1 if problem else 0
