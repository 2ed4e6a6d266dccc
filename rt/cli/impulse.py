"""``frictionrt impulse``: the simulated hammer test (plant.impulse): accelerance FRF, modal damping."""
from __future__ import annotations

import argparse
from pathlib import Path

from frictionrt.rt.cli.structure import add_structure, structure_impulse
from frictionrt.rt.cli.common import spec_default, add_deprecated, add_force, add_out, fail, refuse_existing


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``impulse`` (parents: frictionrt's --config/--set parser)."""
    i = sub.add_parser("impulse", parents=parents, help="simulated hammer test: accelerance FRF, modal damping",
                       description="Hammer impulse (half-sine, impulse.peak_N [N], impulse.duration_s [s]) at "
                                   "the excitation point with constant F_N1 [N]; accelerance FRF "
                                   "[(m/s^2)/N] at the FRF point; natural frequencies [Hz] and damping "
                                   "ratios [-] of bending modes 2-5.")
    i.add_argument("--fn1", type=float, default=None, metavar="N",
                   help=f"adaptive screw force F_N1 [N] (default: {spec_default('plant.screws.adaptive.F_N')}); refused for a "
                        "structure without an adaptive screw")
    add_out(i, "FILE.png", "the file to write the FRF plot to (PNG)", dest="plot")
    add_deprecated(i, "--plot", "-o/--out", dest="plot")
    add_force(i)
    i.add_argument("--error-estimate", action="store_true",
                   help="also run the test with the contact pitch and the elements x2 and give each figure's "
                        "estimated discretisation error: Richardson, order 1 (refined - this: this - coarse); "
                        "about half as long again")
    i.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    add_structure(i)
    return i


def cmd_impulse(cfg, args) -> int:
    if args.structure:
        return structure_impulse(cfg, args)
    from frictionrt.jobs import impulse
    if args.plot:
        out = Path(args.plot)
        if out.suffix.lower() != ".png":
            return fail(f"-o {out}: the plot is written as PNG; give a file name ending in .png")
        if not out.parent.exists():
            return fail(f"-o {out}: folder {out.parent} does not exist")
        if msg := refuse_existing([out], args.force, "-o"):
            return fail(msg)
    try:
        res = impulse(cfg, fn1_n=args.fn1, error_estimate=args.error_estimate)
    except ValueError as exc:
        return fail(str(exc).replace("fn1_n ", "--fn1 ", 1).replace("leave it out", "drop --fn1")
                    .replace("F_N1 ", "--fn1 ", 1))
    if args.plot:
        tmp = out.with_suffix(".tmp.png")
        res.plot().savefig(tmp, dpi=120)
        tmp.replace(out)  # never leave a half-written plot
    if args.json:
        print(res.to_json())
        return 0
    print(res)
    if args.plot:
        print(f"plot: {args.plot}")
    return 0
