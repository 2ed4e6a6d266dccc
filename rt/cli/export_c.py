"""``frictionrt export-c -o DIR`` and ``frictionrt replay RUN.mcap --c DIR`` (rt/export,
docs/export-c.md): the controller as C99 for a real-time target, and the back-to-back replay
that proves it equal to the numba controller bit for bit.

``add_parser(subparsers)`` registers export-c and simulate's --controller c:DIR (software in the
loop, ``controller_of``), ``add_replay_options(parser)`` the replay's --c, --cc, --c-opt,
``add_bench_options`` bench controller's; ``cmd_export_c`` and ``cmd_replay_c`` run them. Bad input (a folder that is
not an export, an export of another design, a missing compiler, a bad log): one line, exit 2.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from rt.cli.common import add_force, add_out, fail

DESCRIPTION = """Write the controller of the resolved configuration (or, with --from-log, of the design a run
log carries) as self-contained C99 into the folder DIR: frictionrt_ctrl.h / .c (ctrl_init, ctrl_step on plain
structs: the tip integrator, the estimator, the law, the supervisor, the prefilter, the force tracking; no heap,
no mutable globals, no libm), the generated parameters (ctrl_design.h, hexadecimal floats), a Makefile (cc
-std=c99 -O2 -ffp-contract=off) and a command-line harness. The design hash (SHA-256 of the controller's numbers)
is in ctrl_config.h and frictionrt_export.json; `frictionrt replay RUN.mcap --c DIR` checks it and compares every
output bit for bit. --estimator oracle gives a test build (inputs u_rel [m], v_rel [m/s] of the plant)."""

EXAMPLES = """examples:
  frictionrt export-c --law lyapunov -o ctrl_lyap && make -C ctrl_lyap
  frictionrt simulate --law lyapunov --estimator observer --freq 223.6 --amp 5 --out logs/lyap
  frictionrt replay logs/lyap.mcap --c ctrl_lyap
  frictionrt export-c --from-log logs/lyap.mcap -o ctrl_lyap --force"""


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    """Register ``export-c`` on an argparse subparsers object."""
    p = subparsers.add_parser("export-c", parents=parents or [], help="the controller as C99 for a real-time "
                              "target (docs/export-c.md)", description=DESCRIPTION, epilog=EXAMPLES,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    add_out(p, "DIR", "the folder to write (created; an existing one only with --force)", required=True)
    p.add_argument("--law", choices=["passive", "hysteresis", "lyapunov"], default=None,
                   help="control law (default: tracking.law)")
    p.add_argument("--estimator", choices=["oracle", "observer"], default="observer",
                   help="observer (default: what a rig runs) or oracle (a test build that reads the plant's u_rel, "
                        "v_rel)")
    p.add_argument("--from-log", metavar="RUN.mcap", default=None,
                   help="export the design a run log carries (its configuration, law, estimator and design "
                        "arrays; --law, --estimator do not apply)")
    add_force(p)
    p.add_argument("--json", action="store_true", help="the manifest as one JSON object")
    subparsers.choices["simulate"].add_argument(
        "--controller", metavar="c:DIR", default=None, help="run the C export in DIR (frictionrt export-c of the same "
        "configuration, law and estimator) as the loop's controller: software in the loop (docs/export-c.md)")
    return p


def controller_of(args, loop):
    """simulate's controller: None (numba) or the C export of --controller c:DIR (rt/export/sil.py);
    ValueError for another form, a folder that is no export or of another design, no compiler."""
    spec = getattr(args, "controller", None)
    if spec is None or spec == "numba":
        return None
    if not spec.startswith("c:") or len(spec) < 3:
        raise ValueError(f"--controller {spec!r}: give c:DIR (a folder of frictionrt export-c) or numba")
    from rt.export.sil import CController
    return CController(loop, Path(spec[2:]), loop.cfg.rt.seed if args.seed is None else args.seed)


def add_replay_options(r: argparse.ArgumentParser) -> None:
    """--c DIR, --cc, --c-opt on ``replay``."""
    r.add_argument("--c", metavar="DIR", default=None, help="replay through the C export in DIR (frictionrt "
                   "export-c) instead of the numba controller, compared bit for bit with the log")
    r.add_argument("--cc", metavar="CC", default=None, help="with --c: the C compiler (default $CC or cc)")
    r.add_argument("--c-opt", metavar="FLAG", default="-O2", help="with --c: the optimisation flag, written --c-opt=-O0 (default -O2)")


def add_bench_options(b: argparse.ArgumentParser) -> None:
    """``bench controller``'s --c DIR, --cc, --law, --estimator."""
    b.add_argument("--c", metavar="DIR", default=None, help="controller: time the C export in DIR beside numba "
                   "(an export of the same configuration, law and estimator)")
    b.add_argument("--cc", metavar="CC", default=None, help="controller with --c: the C compiler (default $CC or cc)")
    b.add_argument("--law", choices=["passive", "hysteresis", "lyapunov"], default="lyapunov",
                   help="controller: the law (default lyapunov)")
    b.add_argument("--estimator", choices=["oracle", "observer"], default="observer",
                   help="controller: the estimator (default observer)")


def cmd_bench_controller(cfg, args) -> int:
    """``bench controller``: per-tick figures [us] of numba and the C export (rt/export/bench.py)."""
    from rt.export.bench import bench_controller, format_bench
    from rt.export.generate import read_manifest
    from rt.loop import build_loop, initial_loop_state
    if args.steps < 1000:
        return fail(f"--steps {args.steps}: need at least 1000 steps")
    try:
        manifest = read_manifest(Path(args.c)) if args.c else None
        loop = build_loop(cfg, args.law, args.estimator)
        res = bench_controller(loop, initial_loop_state(loop, cfg.rt.seed), args.steps, args.c, args.cc, manifest)
    except ValueError as exc:
        return fail(str(exc))
    print(json.dumps(res) if args.json else format_bench(res))
    return 0


def design_hash_of(loop, seed: int) -> str:
    """The design hash of the controller of a run of ``loop`` (``simulate --out`` stores it in the
    log's "frictionrt" record as "controller_design")."""
    from rt.export.record import controller_record, design_hash
    from rt.loop import initial_loop_state
    return design_hash(controller_record(loop, initial_loop_state(loop, seed)))


def cmd_export_c(cfg, args) -> int:
    from rt.export.generate import MANIFEST, export_c
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        return fail(f"--out {out}: exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not args.force:
        return fail(f"--out {out}: exists and is not empty; pass --force to replace the export, or give another name")
    if not out.parent.exists():
        return fail(f"--out {out}: folder {out.parent} does not exist")
    try:
        if args.from_log:
            from rt.export.replay_c import log_design
            _, _, _, loop, st, report = log_design(Path(args.from_log), cfg, args.sets)
            source = f"the log {args.from_log} ({report['why']})"
        else:
            from rt.loop import build_loop, initial_loop_state
            loop = build_loop(cfg, args.law, args.estimator)
            st = initial_loop_state(loop, cfg.rt.seed)
            source = "the resolved configuration"
        m = export_c(loop, st, out, source)
    except ValueError as exc:
        return fail(str(exc))
    if args.json:
        print(json.dumps(m | {"folder": str(out)}))
        return 0
    print(f"export-c {out}: law {m['law']}, estimator {m['estimator']}{' (test build)' if m['estimator'] == 'oracle' else ''}, "
          f"design {m['design_hash']}")
    print(f"  from {m['source']}; {MANIFEST}, C sources, Makefile (make -C {out}), harness ctrl_harness")
    return 0


def cmd_replay_c(cfg, args) -> int:
    """Exit 0 bit-exact, 1 when an output differs, 2 for bad input."""
    from rt.export.replay_c import replay_c
    if args.plant or args.paced:
        return fail("--c replays the controller offline: drop --plant / --paced")
    try:
        res, _ = replay_c(args.log, args.c, cc=args.cc, opt=args.c_opt, fallback_cfg=cfg, sets=args.sets)
    except ValueError as exc:
        return fail(str(exc))
    code = 1 if res["bit_exact"] is False else 0
    if args.json:
        print(json.dumps(res))
        return code
    print(f"replay {res['file']} --c {res['export']}: law {res['law']}, estimator {res['estimator']}, "
          f"{res['ticks']} ticks through the C controller ({res['wall_s'] * 1e3:.1f} ms), design {res['design_hash']}")
    print(f"  build: {res['build']}")
    if res["missing_ticks"]:
        print(f"  the log misses {res['missing_ticks']} ticks (dropped blocks): the states differ after a gap")
    if res["bit_exact"] is None:
        print("  the log records no controller outputs: nothing to compare")
    elif res["bit_exact"]:
        print(f"  bit-exact: {len(res['signals_compared'])} signals x {res['ticks']} ticks "
              f"({', '.join(res['signals_compared'])})")
    else:
        worst = ", ".join(f"{k} {v:.3g}" for k, v in res["max_abs_diff_by_signal"].items() if v)
        print(f"  DIFFERS: first at tick {res['first_mismatch_tick']} in {', '.join(res['first_mismatch_signals'])}; "
              f"max |diff| per signal: {worst}")
    return code
