"""``frictionrt impulse``: the simulated hammer test (plant.impulse): accelerance FRF, modal damping."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from frictionrt.rt.cli.common import add_deprecated, add_force, add_out, fail, refuse_existing
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
    i.add_argument("--error-estimate", action="store_true",
                   help="also run the test with the contact pitch and the elements x2 and give each figure's "
                        "estimated discretisation error: Richardson, order 1 (refined - this: this - coarse); "
                        "about half as long again")
    i.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    return i


def cmd_impulse(cfg, args) -> int:
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
    shift = None
    if args.error_estimate:
        from frictionrt.rt.experiments.discretisation import coarser, refined_shift
        coarse = impulse_test(build_plant(coarser(cfg)), fn1)
        shift = {"freq_hz": [refined_shift(float(a), float(b)) for a, b in zip(res.freq_hz, coarse.freq_hz)],
                 "damping_ratio": [refined_shift(float(a), float(b))
                                   for a, b in zip(res.damping_ratio, coarse.damping_ratio)]}
    if args.plot:
        tmp = out.with_suffix(".tmp.png")
        plot_frf(res, str(tmp), cfg.impulse.f_max_hz)
        tmp.replace(out)  # never leave a half-written plot
    if args.json:
        doc = res.to_json()
        if shift is not None:
            doc["refined_shift"] = {k: [None if v != v else float(f"{v:.6g}") for v in x] for k, x in shift.items()}
        print(json.dumps(doc))
        return 0
    print(f"impulse test, {'no adaptive screw' if screw is None else f'F_N1 = {fn1:g} N'}, "
          f"hammer {cfg.impulse.peak_N:g} N / {1e3 * cfg.impulse.duration_s:g} ms")
    if shift is None:
        print(f"{'mode':>4} {'f [Hz]':>9} {'zeta [%]':>9}")
        for mode, f, z in zip(res.modes, res.freq_hz, res.damping_ratio):
            print(f"{mode:>4} {f:>9.2f} {100 * z:>9.3f}")
    else:
        print("discretisation error: estimated shift under refinement (Richardson from the contact pitch and "
              "elements x2, order 1)")
        print(f"{'mode':>4} {'f [Hz]':>9} {'shift [%]':>9} {'zeta [%]':>9} {'shift [%]':>9}")
        for mode, f, z, df, dz in zip(res.modes, res.freq_hz, res.damping_ratio, shift["freq_hz"],
                                      shift["damping_ratio"]):
            print(f"{mode:>4} {f:>9.2f} {100 * df / f:>+9.2f} {100 * z:>9.3f} {100 * dz / z:>+9.0f}")
    if args.plot:
        print(f"plot: {args.plot}")
    return 0

