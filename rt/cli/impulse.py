"""``frictionrt impulse``: the simulated hammer test (plant.impulse): accelerance FRF, modal damping."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from frictionrt.rt.cli.common import add_deprecated, add_force, add_out, fail, refuse_existing
from frictionrt.rt.cli.structure import add_structure, structure_impulse
from frictionrt.rt.common.config import adaptive_screw


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``impulse`` (parents: frictionrt's --config/--set parser)."""
    i = sub.add_parser("impulse", parents=parents, help="simulated hammer test: accelerance FRF, modal damping",
                       description="Hammer impulse (half-sine, impulse.peak_N [N], impulse.duration_s [s]) at "
                                   "the excitation point with constant F_N1 [N]; accelerance FRF "
                                   "[(m/s^2)/N] at the FRF point; natural frequencies [Hz] and damping "
                                   "ratios [-] of bending modes 2-5.")
    i.add_argument("--fn1", type=float, default=None, metavar="N",
                   help="adaptive screw force F_N1 [N] (default: plant.screws.adaptive.F_N); refused for a "
                        "structure without an adaptive screw")
    add_out(i, "FILE.png", "the file to write the FRF plot to (PNG)", dest="plot")
    add_deprecated(i, "--plot", "-o/--out", dest="plot")
    add_force(i)
    i.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    add_structure(i)
    return i


def cmd_impulse(cfg, args) -> int:
    if args.structure:
        return structure_impulse(cfg, args)
    from frictionrt.plant.impulse import impulse_test, plot_frf
    from frictionrt.plant.model import build_plant
    screw = adaptive_screw(cfg)
    if screw is None and args.fn1 is not None:
        return fail(f"--fn1 {args.fn1:g} N: this structure has no adaptive screw (no plant.screws entry with "
                    "adaptive = true) to set; drop --fn1")
    fn1 = (0.0 if screw is None else screw.F_N) if args.fn1 is None else args.fn1
    t = cfg.tracking
    if screw is not None and not (t.F_min_N <= fn1 <= t.F_max_N):
        return fail(f"--fn1 {fn1:g} N lies outside [F_min, F_max] = [{t.F_min_N:g}, {t.F_max_N:g}] N")
    if args.plot:
        out = Path(args.plot)
        if out.suffix.lower() != ".png":
            return fail(f"-o {out}: the plot is written as PNG; give a file name ending in .png")
        if not out.parent.exists():
            return fail(f"-o {out}: folder {out.parent} does not exist")
        if msg := refuse_existing([out], args.force, "-o"):
            return fail(msg)
    res = impulse_test(build_plant(cfg), fn1)
    if args.plot:
        tmp = out.with_suffix(".tmp.png")
        plot_frf(res, str(tmp), cfg.impulse.f_max_hz)
        tmp.replace(out)  # never leave a half-written plot
    if args.json:
        print(json.dumps(res.to_json()))
        return 0
    print(f"impulse test, {'no adaptive screw' if screw is None else f'F_N1 = {fn1:g} N'}, "
          f"hammer {cfg.impulse.peak_N:g} N / {1e3 * cfg.impulse.duration_s:g} ms")
    print(f"{'mode':>4} {'f [Hz]':>9} {'zeta [%]':>9}")
    for mode, f, z in zip(res.modes, res.freq_hz, res.damping_ratio):
        print(f"{mode:>4} {f:>9.2f} {100 * z:>9.3f}")
    if args.plot:
        print(f"plot: {args.plot}")
    return 0

