"""``frictionrt``: the command-line entry point (one console script, subcommands).

Only the assembly: each verb is a module of rt.cli that owns its parser (``add_parser(sub, parents)``)
and its command (``cmd_VERB(cfg, args)``, the exit code); ``VERBS`` lists them in --help's order,
``frictionrt.rt.cli.common`` holds what they share.

Every subcommand takes ``--config FILE`` and ``--set KEY=VALUE`` (repeatable); quantities
are SI (m, s, N, Hz, Pa, kg) everywhere. Bad input ends with exit code 2 and one message
naming the input and the problem.
"""
from __future__ import annotations

import argparse
import sys

import shtab

from frictionrt.rt.cli import (bench, budget, compare, config, diagnose, export_c, frf, impulse, import_frf, inspect, modes,
                    observer, recover, replay, reproduce, rig, simulate, tune, validate)
from frictionrt.rt.cli.structure import NOT_ON_STRUCTURE, add_structure, refusal
from frictionrt.rt.cli.common import (Parser, actuator_verb, add_common, fail, json_errors, realtime_sets,
                                      split_negative_lists)
from frictionrt.rt.common.config import ConfigError, load, require_adaptive_screw

EPILOG = """units: SI throughout (m, s, N, N/m, Hz, Pa, kg/m^3); forces in N, frequencies in Hz.
examples:
  frictionrt config --show
  frictionrt --set plant.interface.mu=0.3 modes --json
  frictionrt impulse --fn1 100 -o logs/impulse.png
  frictionrt simulate --law lyapunov --freq 223.6 --amp 5 --duration 1 --out logs/lyap
  frictionrt replay logs/lyap.mcap
  frictionrt budget
  frictionrt bench plant --json"""


def version_text() -> str:
    """frictionrt's version and the log format it writes."""
    from importlib.metadata import version

    from frictionrt.rt.log.mcap_log import FORMAT_VERSION
    return f"frictionrt {version('frictionrt')} (log format {FORMAT_VERSION})"


def build_parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    add_common(common, top=False)
    ap = Parser(
        prog="frictionrt", epilog=EPILOG,
        description="Real-time emulation of semi-actively controlled friction dampers (Becker & Gaul).")
    ap.add_argument("--version", action="version", version=version_text())
    shtab.add_argument_to(ap, "--print-completion", help="print the shell completion script of every verb and "
                          "option, generated from this parser (README, \"Shell completion\")")
    add_common(ap, top=True)
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, verb in VERBS.items():
        p = verb.add_parser(sub, parents=[common])
        if name in NOT_ON_STRUCTURE:
            add_structure(p)
    return ap


VERBS = {"config": config, "modes": modes, "impulse": impulse, "simulate": simulate, "compare": compare,
         "budget": budget, "observer": observer, "replay": replay, "bench": bench, "frf": frf,
         "validate": validate, "reproduce": reproduce, "tune": tune, "rig": rig, "diagnose": diagnose,
         "recover": recover, "inspect": inspect, "export-c": export_c, "import-frf": import_frf}
"""Each verb's module, in the order --help lists them."""

COMMANDS = {name: getattr(module, f"cmd_{name.replace('-', '_')}") for name, module in VERBS.items()}
"""Each verb's command: ``cmd_VERB`` of its module (``-`` in a verb's name is ``_``: export-c, cmd_export_c)."""


def main(argv: list[str] | None = None) -> int:
    argv = split_negative_lists(sys.argv[1:] if argv is None else list(argv))
    json_errors("--json" in argv)   # for this command line only (rt.cli.common)
    try:
        return _main(build_parser().parse_args(argv))
    except BrokenPipeError:
        return _closed_pipe()
    finally:
        json_errors(False)


def _closed_pipe() -> int:
    """The reader of stdout went away (``frictionrt ... | head``): end quietly with 141 (128 +
    SIGPIPE, what a shell reports for a command killed by the signal). stdout is pointed at
    /dev/null so that the interpreter's final flush does not raise again."""
    import os
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass
    return 141


def _main(args) -> int:
    try:
        args.sets = [*args.sets, *realtime_sets(args)]  # --rt-priority, --cpu (replay: onto the stored configuration)
        cfg = load(args.config, args.sets)
        if verb := actuator_verb(args):
            require_adaptive_screw(cfg, verb)   # one line instead of a failure deep in the loop's design
    except ConfigError as exc:
        return fail(str(exc))
    if getattr(args, "structure", None) and args.command in NOT_ON_STRUCTURE:
        return fail(refusal(args.command))
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
