"""Stress sweep of the plant's contact solve (docs/plant.md 2.3, 2.6): does every step converge?

    python -m benchmarks.contact_stress [--set KEY=VALUE ...]

The plant alone (plant.simulate.run) over 0.2 s per run, on a grid of normal contact stiffness
k_n per unit area (2.5e11, 1.25e12, 1.25e13 N/m^3: 2e8, 1e9, 1e10 N/m on a 20 x 40 mm pair; k_t stays at its default, so the pairs' k_t / k_n ratio varies too), constant F_N1 (40, 100, 600 N) and excitations at the excitation
point: half-sine hammers of 50 and 500 N (0.5 ms), sines of 40 and 500 N at 220 Hz (36 runs).
Per run: substep fallbacks (Newton stalled, redone on plant.fallback_split fine substeps), whether
the run failed (a fine substep did not converge either), and the Newton iterations per step
(mean, max). Prints one line per run that fell back or failed, then the totals.
"""
from __future__ import annotations

import argparse

import numpy as np

from frictionrt.plant.impulse import hammer_force
from frictionrt.plant.model import build_plant
from frictionrt.plant.simulate import run
from frictionrt.rt.common.config import load
from benchmarks.entry import run_main

K_N = (2.5e11, 1.25e12, 1.25e13)   # [N/m^3]
F_N1 = (40.0, 100.0, 600.0)
RECORD_S = 0.2


def excitations(dt: float) -> dict[str, np.ndarray]:
    """The four excitation records [N] of RECORD_S at step dt [s]."""
    n = int(round(RECORD_S / dt))
    t = np.arange(n) * dt
    return {"hammer 50 N": hammer_force(n, dt, 50.0, 0.5e-3), "hammer 500 N": hammer_force(n, dt, 500.0, 0.5e-3),
            "sine 40 N": 40.0 * np.sin(2 * np.pi * 220.0 * t), "sine 500 N": 500.0 * np.sin(2 * np.pi * 220.0 * t)}


def sweep(sets: list[str]) -> list[dict]:
    """One row per run (module docstring)."""
    rows = []
    for k_n in K_N:
        model = build_plant(load(None, sets + [f"plant.interface.k_n_area={k_n}"]))
        idx = model.output_index()
        for fn1 in F_N1:
            for name, F in excitations(model.cfg.dt_s).items():
                row = {"k_n": k_n, "F_N1": fn1, "excitation": name}
                try:
                    Y, _, _ = run(model, F, fn1, x0=model.initial_state(fn1))
                    it = Y[:, idx["newton_iter"]]
                    row.update(failed=False, fallbacks=int(Y[:, idx["substep_fallbacks"]].sum()),
                               newton_mean=float(it.mean()), newton_max=int(it.max()))
                except RuntimeError:
                    row.update(failed=True, fallbacks=-1, newton_mean=float("nan"), newton_max=-1)
                rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE",
                    help="configuration override for every run, e.g. plant.quasi_static_theta=0")
    args = ap.parse_args(argv)
    rows = sweep(args.sets)
    for r in rows:
        if r["failed"] or r["fallbacks"]:
            what = "FAILED" if r["failed"] else f"{r['fallbacks']} fallbacks"
            print(f"k_n_area {r['k_n']:.2e}  F_N1 {r['F_N1']:5.0f} N  {r['excitation']:13s}: {what}")
    ok = [r for r in rows if not r["failed"]]
    print(f"{len(rows)} runs: {sum(r['failed'] for r in rows)} failed, "
          f"{sum(r['fallbacks'] for r in ok)} fallback substeps; Newton iterations per step "
          f"mean {np.mean([r['newton_mean'] for r in ok]):.3f}, max {max(r['newton_max'] for r in ok)}")
    return 0


if __name__ == "__main__":
    run_main(main)
