"""Convergence of the hammer test's FRF in the plant's time step (docs/discrepancy.md, "Which part of
the model form hides an effect"), beside the signatures of the joint's friction-law effects.

    python -m benchmarks.substep_convergence [--substeps 1 2 4 8] [--set KEY=VALUE ...]

Per F_N1 level of the rig's impulse tests (40, 100, 300 N) the plant (plant.simulate.run, no sensors)
is hit by the rig's nominal hammer (50 N, 0.5 ms, rt.discrepancy.rig) at each number of substeps per
controller step (``plant.substeps``; the step h = dt / substeps); the accelerance a_frf / F is the
FFT of the 1 s response under the diagnosis's exponential window (tau = T / 4) over the hammer's
FFT. Printed: the RMS of 20 log10 |H_s / H_finest| [dB] over 50-1200 Hz (the diagnosis's gap band)
for each s, for the configured friction and with mu = 2 (stuck at 300 N: there only the trapezoidal
rule's period error, (pi f h)^2 / 3, differs, which the diagnosis's dispersion c takes), and the
same measure for micro_slip and stribeck at their default strengths against the plant without them
at the coarsest step: what the diagnosis has to see through the step's error. With the modes
period-matched (docs/plant.md 2.2) and the 10 mm default, the 100 N test's error against 8 substeps
is 0.53 / 0.37 / 0.05 dB at 1 / 2 / 4 substeps, the stuck 300 N test's 0.88 / 0.43 / 0.06 dB (on the
20 mm plain-trapezoid plant the slipping test converged at first order, 4.39 / 2.47 / 1.31 dB).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.entry import run_main
from frictionrt.plant.impulse import hammer_force
from frictionrt.plant.model import build_plant
from frictionrt.plant.simulate import run
from frictionrt.rt.common.config import Config, load, with_sets
from frictionrt.rt.discrepancy.effects import get
from frictionrt.rt.discrepancy.rig import FN1_LEVELS_N, HAMMER_CONTACT_S, HAMMER_PEAK_N

BAND_HZ = (50.0, 1200.0)
RECORD_S = 1.0


def accelerance(cfg: Config, F_N1: float) -> np.ndarray:
    """a_frf / F [(m/s^2)/N] of the windowed 1 s hammer test at F_N1 [N] over ``BAND_HZ`` (bins of 1 Hz)."""
    dt = cfg.dt_s
    n = int(round(RECORD_S / dt))
    F = hammer_force(n, dt, HAMMER_PEAK_N, HAMMER_CONTACT_S)
    model = build_plant(cfg)
    Y, _, _ = run(model, F, F_N1)
    f = np.fft.rfftfreq(n, dt)
    band = (f > BAND_HZ[0]) & (f < BAND_HZ[1])
    a = Y[:, model.output_index()["a_frf"]] * np.exp(-np.arange(n) * dt / (RECORD_S / 4))
    return np.fft.rfft(a)[band] / np.fft.rfft(F)[band]


def rms_db(H: np.ndarray, ref: np.ndarray) -> float:
    """RMS of 20 log10 |H / ref| [dB]."""
    return float(np.sqrt(np.mean((20.0 * np.log10(np.abs(H / ref))) ** 2)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--substeps", type=int, nargs="+", default=[1, 2, 4, 8],
                    help="substeps per controller step; the last is the reference (default 1 2 4 8)")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    if sorted(args.substeps) != args.substeps or args.substeps[0] < 1:
        ap.error(f"--substeps {args.substeps}: give increasing positive counts, the finest last, e.g. 1 2 4 8")
    base = load(None, args.sets)
    s0, s_ref = args.substeps[0], args.substeps[-1]
    effects = [get("micro_slip"), get("stribeck")]
    print(f"RMS of 20 log10 |H / H_{s_ref} substeps| over {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz [dB], a_frf, "
          f"{HAMMER_PEAK_N:g} N hammer\n")
    print("| F_N1 [N] | friction | " + " | ".join(f"{s} substep{'s' * (s > 1)}" for s in args.substeps[:-1])
          + " | " + " | ".join(f"{e.name} {e.parameter.default:g} at {s0} substep{'s' * (s0 > 1)}" for e in effects)
          + " | s |")
    print("| --- | --- |" + " --- |" * (len(args.substeps) - 1 + len(effects) + 1), flush=True)
    for F_N1 in FN1_LEVELS_N:
        for label, sets in (("configured", []), ("mu = 2", ["plant.interface.mu=2.0"])):
            t0 = time.perf_counter()
            cfg = with_sets(base, sets)
            H = {s: accelerance(with_sets(cfg, [f"plant.substeps={s}"]), F_N1) for s in args.substeps}
            sig = [rms_db(accelerance(with_sets(e.apply(cfg, e.parameter.default), [f"plant.substeps={s0}"]), F_N1),
                          H[s0]) for e in effects]
            print(f"| {F_N1:g} | {label} | " + " | ".join(f"{rms_db(H[s], H[s_ref]):.2f}" for s in args.substeps[:-1])
                  + " | " + " | ".join(f"{v:.2f}" for v in sig) + f" | {time.perf_counter() - t0:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    run_main(main)
