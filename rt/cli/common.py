"""What every ``frictionrt`` verb does the same way (below the verbs; rt/cli/app.py assembles them).

- Errors: ``fail(msg)`` prints one line ``frictionrt: error: MSG`` on stderr and returns exit
  code 2; with ``--json`` the same error is also one JSON object on stdout,
  ``{"error": MSG, "exit": 2}`` (``json_errors`` switches it on for the command line being run;
  ``Parser`` does the same for argparse's own usage errors).
- Options: ``--config``/``--set`` on every verb (``add_common``), comma-separated lists (``parse_list``),
  the paced loop's ``--rt-priority``/``--cpu`` (``add_realtime``, ``realtime_sets``).
- Output: ``-o``/``--out`` names where a verb writes (``add_out``): the one file it writes (its
  viewer companions beside it, named after it), or a folder it creates; an existing output is
  refused unless ``--force`` (``add_force``, ``refuse_existing``), which replaces it (a folder as a
  whole: ``frictionrt.rt.common.files.write_folder``). Old spellings stay for one release with a one-line note
  (``add_deprecated``). docs/commands.md, "Where a verb writes", has the table.
- Help: one formatter for every verb (``HelpFormatter``: defaults shown as "(default: VALUE)").
"""
from __future__ import annotations

import argparse
import json
import re
import sys
import textwrap
from pathlib import Path

import shtab

_json_errors = False


def json_errors(on: bool) -> None:
    """Errors of the command being run also as a JSON object on stdout (its --json)."""
    global _json_errors
    _json_errors = bool(on)


def fail(msg: str) -> int:
    """Report a bad input or a failed precondition: one stderr line (and the JSON object with
    --json); returns the exit code 2."""
    print(f"frictionrt: error: {msg}", file=sys.stderr)
    if _json_errors:
        print(json.dumps({"error": msg, "exit": 2}))
    return 2


class Parser(argparse.ArgumentParser):
    """argparse's parser whose usage errors follow ``fail`` (JSON on stdout if --json was given); its
    --help, and every verb's (argparse makes the verbs' parsers of the same class), in ``HelpFormatter``."""

    def __init__(self, *args, **kw):
        kw.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kw)

    def error(self, message: str):
        if _json_errors:
            print(json.dumps({"error": f"{self.prog}: {message}", "exit": 2}))
        super().error(message)


def add_out(p: argparse.ArgumentParser, metavar: str, help: str, **kw) -> None:
    """-o/--out: where the verb writes; ``help`` starts with what it names: "the file ..." or "a
    folder it creates ..." (docs/commands.md, "Where a verb writes")."""
    assert help.startswith(("the file", "a folder")), help
    p.add_argument("-o", "--out", metavar=metavar, help=help, **kw)


def add_force(p: argparse.ArgumentParser, what: str = "existing output files") -> None:
    """--force: replace an existing output."""
    p.add_argument("--force", action="store_true", help=f"replace {what} (otherwise refused)")


def refuse_existing(paths, force: bool, option: str = "--out") -> str | None:
    """The error message if one of ``paths`` exists and not ``force``, else None."""
    if force:
        return None
    for p in map(Path, paths):
        if p.exists():
            return f"{option} {p}: exists; pass --force to replace it, or give another name"
    return None


def add_common(p: argparse.ArgumentParser, top: bool) -> None:
    """--config and --set, accepted before or after the subcommand. The subcommands' copies
    default to SUPPRESS so they never overwrite what was given before the subcommand."""
    dflt = (lambda v: v) if top else (lambda v: argparse.SUPPRESS)
    p.add_argument("--config", metavar="FILE", default=dflt(None),
                   help="TOML file overriding the defaults (SPEC values)").complete = shtab.FILE
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=dflt([]), dest="sets",
                   help="override one value, e.g. plant.interface.mu=0.3 or plant.screws.adaptive.F_N=200 "
                        "(list elements by name); repeatable")


class CommaList(argparse.Action):
    """A list option in the one syntax of every verb: comma-separated values (``--amps 5,20``),
    converted by ``kind`` (float, int, or a ``choices`` check for names). The old spelling,
    space-separated values (``--amp 5 20``), is accepted with a one-line note. Values that start
    with a minus sign (``--freqs -5,200``) reach the option too (``split_negative_lists``)."""

    def __init__(self, option_strings, dest, kind=float, example: str = "5,20", allowed=None, **kw):
        self.kind, self.example, self.allowed = kind, example, allowed
        kw.setdefault("nargs", "+")
        super().__init__(option_strings, dest, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        values = values if isinstance(values, list) else [values]
        if len(values) > 1:
            deprecated(f"{option_string} {' '.join(values)} (space-separated)", f"{option_string} {','.join(values)}")
        text = ",".join(values)
        try:
            items = parse_list(text, self.kind, option_string, self.example)
        except ValueError as exc:
            parser.error(str(exc))
        if self.allowed is not None:
            bad = [v for v in items if v not in self.allowed]
            if bad:
                parser.error(f"{option_string} {bad[0]!r}: give one or more of {', '.join(self.allowed)}, comma-separated")
        setattr(namespace, self.dest, items)


LIST_VALUE = re.compile(r"^-[\d.]+(?:[eE][+-]?\d+)?,")


def split_negative_lists(argv: list[str]) -> list[str]:
    """argv with an option's comma list that starts with a minus sign joined to it
    (``--freqs -5,200`` -> ``--freqs=-5,200``): argparse would take ``-5,200`` for an option and
    say only "expected one argument"; joined, the value reaches the option's own check."""
    out: list[str] = []
    for a in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and LIST_VALUE.match(a):
            out[-1] = f"{out[-1]}={a}"
        else:
            out.append(a)
    return out


def parse_list(text: str, kind, option: str, example: str) -> list:
    """The comma-separated values of an option (``kind`` each, e.g. float); ValueError naming
    the option and an example when one is not a number or the list is empty."""
    try:
        values = [kind(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"{option} {text!r}: give comma-separated numbers, e.g. {example}") from None
    if not values:
        raise ValueError(f"{option} {text!r}: empty list; give at least one value, e.g. {example}")
    return values


def spec_default(key: str) -> str:
    """``KEY = VALUE`` of the spec's default configuration, for --help texts whose default is a
    configuration key (e.g. "tracking.law = hysteresis"): --config/--set may change it."""
    from frictionrt.rt.common.config import Config
    obj = Config()
    for part in key.split("."):
        obj = next(x for x in obj if x.name == part) if isinstance(obj, tuple) else getattr(obj, part)
    return f"{key} = {obj:g}" if isinstance(obj, float) else f"{key} = {obj}"


def add_estimator(p: argparse.ArgumentParser, both: bool = False) -> None:
    """--estimator: what the laws run on (``Estimator``; the observer by default); ``both``: also
    "both", the default then (reproduce: the claims on the observer, the oracle beside them)."""
    from frictionrt.rt.common.config import ALL_ESTIMATORS, DEFAULT_ESTIMATOR
    choices = (*ALL_ESTIMATORS, "both") if both else ALL_ESTIMATORS
    p.add_argument("--estimator", choices=choices, default="both" if both else DEFAULT_ESTIMATOR.value,
                   help="observer: the paper's Kalman-designed observer on the tip accelerometer and the force cell; "
                        "oracle: the plant's own band-limited u_rel, v_rel (the upper bound); amplitude: the paper's observer "
                        "with each mode's frequency following its amplitude"
                        + ("; both: the claims on the observer, the oracle beside them" if both else ""))


def add_realtime(p: argparse.ArgumentParser) -> None:
    """--rt-priority and --cpu: the paced loop's real-time set-up (rt.priority, rt.cpu;
    rt/loop/realtime.py). Off by default; without the privilege a paced run says so in one line."""
    p.add_argument("--rt-priority", type=int, default=None, metavar="N",
                   help="paced: run the loop thread alone at SCHED_FIFO priority N (1-99; rt.priority); memory "
                        "locked, /dev/cpu_dma_latency held at 0")
    p.add_argument("--cpu", type=int, default=None, metavar="K",
                   help="paced: pin the loop thread to core K, the writer and Python to the others (rt.cpu)")


def realtime_sets(args) -> list[str]:
    """The --set assignments that --rt-priority / --cpu stand for (none if not given)."""
    out = []
    if getattr(args, "rt_priority", None) is not None:
        out.append(f"rt.priority={args.rt_priority}")
    if getattr(args, "cpu", None) is not None:
        out.append(f"rt.cpu={args.cpu}")
    return out


def unpaced_realtime(args) -> str | None:
    """The error for --rt-priority / --cpu without --paced (they set up a paced run only)."""
    if (getattr(args, "rt_priority", None) is not None or getattr(args, "cpu", None) is not None) \
            and not getattr(args, "paced", False):
        return "--rt-priority / --cpu set up a paced run: add --paced (an offline run is not paced to the clock)"
    return None


def realtime_notes(rt: dict | None) -> None:
    """One stderr line per piece of the real-time set-up the run asked for and did not get."""
    for note in (rt or {}).get("notes", ()):
        print(f"frictionrt: note: {note}", file=sys.stderr)


def add_controller(p: argparse.ArgumentParser, many: bool = False) -> None:
    """--controller c:DIR: a C export (frictionrt export-c) as the loop's controller, software in
    the loop (docs/export-c.md); ``many``: repeatable, one export per law the verb runs."""
    what = ("the controller of the law it was exported for (repeatable: one export per law; the other laws run "
            "the numba controller)" if many else "the loop's controller")
    p.add_argument("--controller", metavar="c:DIR", default=[] if many else None, action="append" if many else "store",
                   help=f"run the C export in DIR (frictionrt export-c of the same configuration, law and estimator) "
                        f"as {what}: software in the loop (docs/export-c.md; default: the numba controller)")


def c_exports(specs, runs) -> dict[tuple[str, str], Path]:
    """The folders of --controller c:DIR (``specs``: None, one value or a list; "numba" stands for
    none) by the (law, estimator) each was exported for, among ``runs``, the (law, estimator) pairs
    the verb runs. ValueError in one line for another form, a folder that is no export, an export
    of a law and estimator the verb does not run ("an export of another design"), two for one."""
    from frictionrt.rt.export.generate import read_manifest, require_double
    specs = [] if specs is None else [specs] if isinstance(specs, str) else list(specs)
    out: dict[tuple[str, str], Path] = {}
    for spec in specs:
        if spec == "numba":
            continue
        if not spec.startswith("c:") or len(spec) < 3:
            raise ValueError(f"--controller {spec!r}: give c:DIR (a folder of frictionrt export-c) or numba")
        folder = Path(spec[2:])
        m = read_manifest(folder)
        require_double(m, f"--controller {spec}")
        key = (m.get("law"), m.get("estimator"))
        if key not in runs:
            raise ValueError(f"--controller {spec}: an export of another design ({m['design_hash'][:19]}..., "
                             f"{key[0]}/{key[1]}) than this run's ({', '.join(f'{a}/{b}' for a, b in runs)})")
        if key in out:
            raise ValueError(f"--controller {spec}: a second export for {key[0]}/{key[1]} (c:{out[key]}); give one")
        out[key] = folder
    return out


def controller_for(exports: dict, loop, seed: int):
    """The controller of ``loop`` (``frictionrt.rt.loop.driver.run(..., controller=)``): the C export among
    ``exports`` (``c_exports``) for its law and estimator (``frictionrt.rt.export.sil.CController``: ValueError
    for an export of another design), else None (the numba controller)."""
    folder = exports.get((loop.law, loop.estimator))
    if folder is None:
        return None
    from frictionrt.rt.export.sil import CController
    return CController(loop, folder, seed)


ACTUATOR_VERBS = ("simulate", "compare", "budget", "observer", "replay", "frf", "tune", "reproduce", "export-c")
"""Verbs that drive the adaptive screw's actuator (or design for it) whatever their options."""


def actuator_verb(args) -> str | None:
    """The command as the user wrote it if it needs the adaptive screw (the actuator, the closed
    loop or a time-series campaign with actuator tests), else None: ``ACTUATOR_VERBS``, ``bench
    loop``, ``rig`` without --list or --frf-files, ``diagnose`` of a folder that is not one of FRF
    files (docs/plant.md 5.3)."""
    verb = args.command
    if verb in ACTUATOR_VERBS:
        return verb
    if verb == "bench" and args.target in ("loop", "controller"):
        return f"bench {args.target}"
    if verb == "rig" and not (args.list or args.frf_files):
        return "rig (the time-series campaign; --frf-files writes FRF files without it)"
    if verb == "diagnose" and Path(args.folder).is_dir():   # a missing folder: diagnose's own message
        from frictionrt.rt.discrepancy.diagnose import is_frf_folder
        if not is_frf_folder(args.folder):
            return "diagnose of a time-series campaign"
    return None


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """The one --help layout of every verb: descriptions and epilogs reflowed paragraph by paragraph
    (indented lines, e.g. the examples, kept as written), and each option's default shown at the end
    of its help as "(default: VALUE)" unless the help already says what the default is."""

    def _fill_text(self, text, width, indent):
        out, para = [], []

        def flush():
            if para:
                out.append(textwrap.fill(" ".join(para), width, initial_indent=indent, subsequent_indent=indent,
                                         break_on_hyphens=False))
                para.clear()
        for line in textwrap.dedent(text).splitlines():
            if not line.strip() or line.startswith(" ") or line.rstrip().endswith(":"):   # kept as written
                flush()
                out.append(indent + line if line.strip() else "")
            else:
                para.append(line.strip())
        flush()
        return "\n".join(out)

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if ("default" in text or default is None or default is False or default == [] or default is argparse.SUPPRESS
                or not action.option_strings):
            return text
        return text + " (default: %(default)s)"


class DeprecatedSpelling(argparse.Action):
    """An old spelling of an option, kept for one release: stores like the new one (same ``dest``), says
    in one stderr line which spelling replaces it, and is left out of --help."""

    def __init__(self, option_strings, dest, new: str = "", **kw):
        kw.setdefault("help", argparse.SUPPRESS)
        super().__init__(option_strings, dest, **kw)
        self.new = new

    def __call__(self, parser, namespace, values, option_string=None):
        deprecated(option_string, self.new)
        setattr(namespace, self.dest, values)


def add_deprecated(p: argparse.ArgumentParser, old: str, new: str, dest: str = "out", **kw) -> None:
    """Keep the old spelling ``old`` of the option now spelled ``new`` (``DeprecatedSpelling``)."""
    p.add_argument(old, dest=dest, action=DeprecatedSpelling, new=new, default=argparse.SUPPRESS, **kw)


def deprecated(old: str, new: str) -> None:
    """The one-line note for an old spelling kept for one release."""
    print(f"frictionrt: note: {old} is deprecated and goes in the next release; say {new}", file=sys.stderr)
