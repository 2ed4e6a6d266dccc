"""``frictionrt export-c -o DIR`` (rt/export, docs/export-c.md): the controller as C99 for a real-time
target. The C export's other uses belong to their verbs: ``replay RUN.mcap --c DIR`` (the back-to-back
replay that proves it equal to the numba controller bit for bit, rt.cli.replay), ``simulate --controller
c:DIR`` (software in the loop, rt.cli.simulate), ``bench controller --c DIR`` (rt.cli.bench). Bad input (a
log that carries no design, a folder that exists): one line, exit 2.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import shtab

from frictionrt.rt.cli.common import spec_default, add_estimator, add_force, add_out, fail
from frictionrt.rt.cli.structure import add_structure

DESCRIPTION = """Write the controller of the resolved configuration (or, with --from-log, of the design a run
log carries) as self-contained C99 into the folder DIR: frictionrt_ctrl.h / .c (ctrl_init, ctrl_step on plain
structs: the tip integrator, the estimator, the law, the supervisor, the prefilter, the force tracking; no heap,
no mutable globals, no libm), the generated parameters (ctrl_design.h, hexadecimal floats), a Makefile (cc
-std=c99 -O2 -ffp-contract=off), a command-line harness, and golden vectors with `make check` (ctrl_check.c: the
compiled controller against the design's own simulation, bit for bit, without Python). ctrl_init checks the build's
arithmetic and the parameters' checksum at run time. The design hash (SHA-256 of the controller's numbers)
is in ctrl_config.h and frictionrt_export.json; `frictionrt replay RUN.mcap --c DIR` checks it and compares every
output bit for bit. --estimator oracle gives a test build (inputs u_rel [m], v_rel [m/s] of the plant)."""

EXAMPLES = """examples:
  frictionrt export-c --law lyapunov -o ctrl_lyap && make -C ctrl_lyap check
  frictionrt simulate --law lyapunov --estimator observer --freq 223.6 --amp 5 --out logs/lyap
  frictionrt replay logs/lyap.mcap --c ctrl_lyap
  frictionrt export-c --from-log logs/lyap.mcap -o ctrl_lyap --force
  frictionrt export-c --law lyapunov --precision float32 -o ctrl_lyap_f32 && make -C ctrl_lyap_f32 check"""


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``export-c`` (parents: frictionrt's --config/--set parser)."""
    p = sub.add_parser("export-c", parents=parents, help="the controller as C99 for a real-time target "
                       "(docs/export-c.md)", description=DESCRIPTION, epilog=EXAMPLES)
    add_out(p, "DIR", "a folder it creates for frictionrt_ctrl.h/.c, ctrl_design.h, ctrl_config.h, config.toml, "
                      "Makefile, the harness and frictionrt_export.json (required; its parent folder must exist); "
                      "an existing one (not empty) is refused, or with --force replaced as a whole", required=True)
    p.add_argument("--law", choices=["passive", "hysteresis", "lyapunov"], default=None,
                   help=f"control law (default: {spec_default('tracking.law')})")
    add_estimator(p)
    p.add_argument("--from-log", metavar="RUN.mcap", default=None,
                   help="export the design a run log carries (its configuration, law, estimator and design "
                        "arrays; --law, --estimator do not apply)").complete = shtab.FILE
    p.add_argument("--precision", choices=["double", "float32"], default="double",
                   help="double: bit-exact with the numba controller (default); float32: single precision for a "
                        "core with a single-precision FPU only (Cortex-M4F), within a stated bound of the double "
                        "controller, its own golden vectors (observer build; needs a C compiler at export time)")
    add_force(p, "an existing folder as a whole")
    p.add_argument("--json", action="store_true", help="the manifest as one JSON object")
    add_structure(p)
    return p


def cmd_export_c(cfg, args) -> int:
    from frictionrt.jobs import export_c
    from frictionrt.rt.export.generate import MANIFEST
    out = Path(args.out)
    if args.precision == "float32" and args.from_log is None and args.estimator != "observer":  # before the design
        return fail(f"export-c --precision float32: only the observer build (--estimator observer), not "
                    f"{args.estimator!r}; export {args.estimator} without --precision (the double kind)")
    try:
        m = export_c(cfg, out=out, law=args.law, estimator=args.estimator, from_log=args.from_log, sets=args.sets,
                     force=args.force, precision=args.precision, structure=args.structure,
                     clusters=args.clusters, clustering=args.clustering).to_dict()
    except FileExistsError:
        return fail(f"--out {out}: exists; pass --force to replace it as a whole, or give a new folder")
    except ValueError as exc:
        return fail(str(exc).replace("out ", "--out ", 1) if str(exc).startswith("out ") else str(exc))
    if args.json:
        print(json.dumps(m))
        return 0
    print(f"export-c {out}: law {m['law']}, estimator {m['estimator']}{' (test build)' if m['estimator'] == 'oracle' else ''}, "
          f"design {m['design_hash']}" + (", float32 kind" if m.get("precision") == "float32" else ""))
    harness = "" if m.get("precision") == "float32" else "harness ctrl_harness, "
    print(f"  from {m['source']}; {MANIFEST}, C sources, Makefile (make -C {out}), {harness}"
          f"golden vectors ({m['golden']['ticks']} ticks: make -C {out} check)")
    return 0
