"""Derive the interface's default normal stiffness from what the paper observed (docs/plant.md 6).

    python -m benchmarks.calibrate_contact [--target-hz 230] [--set KEY=VALUE ...]

The paper observes the friction-affected mode-3 peak near 230 Hz (215..235 Hz) in the impulse
FRF at F_N1 = 100 N, F_N2 = 6000 N (Fig. 5). With the tangential stiffness tied to the normal one
by Mindlin's ratio for steel, k_t = 2 (1 - nu) / (2 - nu) k_n = 0.82 k_n, the one free number is
k_n per unit area [N/m^3]: the script runs the simulated hammer test (plant.impulse, 50 N) on a log grid of
k_n, interpolates log k_n at the target frequency and checks the result by one more test. Nothing
the model is then to predict (the claims C2..C6, the laws' reductions, the Jenkins parameters at
the adaptive screw) enters. The printed value is rt/common/config.py's default.
"""
from __future__ import annotations

import argparse

import numpy as np

from frictionrt.plant.impulse import impulse_test
from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import load
from benchmarks.entry import run_main

MINDLIN = 2 * (1 - 0.3) / (2 - 0.3)   # k_t / k_n for nu = 0.3
F_N1 = 100.0


def mode3_hz(sets: list[str], k_n: float) -> tuple[float, float]:
    """(f [Hz], zeta [-]) of mode 3 in the 100 N hammer test at normal stiffness k_n [N/m^3] per
    unit area (k_t per area = MINDLIN k_n)."""
    cfg = load(None, sets + [f"plant.interface.k_n_area={float(k_n)!r}",
                             f"plant.interface.k_t_area={float(MINDLIN * k_n)!r}"])
    r = impulse_test(build_plant(cfg), F_N1)
    i = list(r.modes).index(3)
    return float(r.freq_hz[i]), float(r.damping_ratio[i])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--target-hz", type=float, default=230.0)
    ap.add_argument("--grid", type=float, nargs="+", default=list(np.geomspace(1e12, 1e13, 6)))
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args(argv)
    f = []
    for k in args.grid:
        f3, z3 = mode3_hz(args.sets, k)
        f.append(f3)
        print(f"k_n_area {k:.3e} N/m^3, k_t_area {MINDLIN * k:.3e} N/m^3: mode 3 at {f3:.2f} Hz, zeta {100 * z3:.3f} %", flush=True)
    f = np.array(f)
    if not (f.min() <= args.target_hz <= f.max()) or np.any(np.diff(f) <= 0):
        print("the target lies outside the grid's range or f3(k_n) is not increasing: widen --grid")
        return 1
    k_cal = float(10 ** np.interp(args.target_hz, f, np.log10(args.grid)))
    k_cal = float(f"{k_cal:.2g}")
    f3, z3 = mode3_hz(args.sets, k_cal)
    print(f"calibrated: k_n_area = {k_cal:.2g} N/m^3, k_t_area = {MINDLIN * k_cal:.3g} N/m^3: mode 3 at {f3:.2f} Hz "
          f"(target {args.target_hz:g}), zeta {100 * z3:.3f} %")
    return 0


if __name__ == "__main__":
    run_main(main)
