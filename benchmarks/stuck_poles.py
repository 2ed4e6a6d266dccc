"""The stuck, preloaded plant's stepped poles per step scheme, with the open-contact period matching
(plant.period_match) and with the stuck one (plant.period_match_stuck; docs/plant.md 2.9).

    python -m benchmarks.stuck_poles [--schemes trapezoidal generalized_alpha] [--substeps 1]
                                     [--fn1 40] [--set KEY=VALUE ...]

Poles: the step's linear map about the static state at F_N1 (plant.stuck_match.step_map, pairs
closed by the preload stuck), its oscillatory poles below omega h = 1 against the same step with
h / 64 (the reference): per pole the reference's f [Hz] and zeta [%], and each variant's offsets
(f [%], zeta [% of zeta]). The hammer tests of both matchings: benchmarks.stuck_match_ab.
"""
from __future__ import annotations

import argparse

import numpy as np

from benchmarks.entry import run_main
from frictionrt.plant.model import build_plant, stuck_reference
from frictionrt.plant.stuck_match import poles, reference_poles, step_map
from frictionrt.rt.common.config import STEP_SCHEMES, load, with_sets

VARIANTS = (("open-contact matching", ["plant.period_match_stuck=false"]),
            ("stuck matching", ["plant.period_match_stuck=true"]))


def pole_table(cfg, F_N1: float) -> None:
    """Per reference pole below omega h = 1: f [Hz], zeta [%], and each variant's offsets."""
    h = build_plant(cfg).params.h
    ref = reference_poles(stuck_reference(cfg), h, 1.0, F_N1)
    cols = []
    for _, sets in VARIANTS:
        model = build_plant(with_sets(cfg, sets))
        p = model.params._replace(substeps=1)
        s = poles(step_map(model, p, F_N1), p.h)
        cols.append(s[np.argmin(np.abs(np.log(s[:, None] / ref[None, :])), axis=0)])
    print("| f_ref [Hz] | zeta_ref [%] | " + " | ".join(f"{v}: f [%], zeta [%]" for v, _ in VARIANTS) + " |")
    print("| --- | --- |" + " --- |" * len(VARIANTS))
    for k, r in enumerate(ref):
        z_r = -r.real / abs(r)
        cells = []
        for s in cols:
            z = -s[k].real / abs(s[k])
            cells.append(f"{100 * (abs(s[k]) / abs(r) - 1):+.4f}, {100 * (z / z_r - 1):+.1f}")
        print(f"| {abs(r) / 2 / np.pi:.1f} | {100 * z_r:.3f} | " + " | ".join(cells) + " |", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--schemes", nargs="+", default=list(STEP_SCHEMES), choices=STEP_SCHEMES)
    ap.add_argument("--substeps", type=int, default=1, help="the plant's substeps (default 1)")
    ap.add_argument("--fn1", type=float, default=40.0, help="F_N1 [N] of the static state (default 40)")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    if args.substeps < 1:
        ap.error(f"--substeps {args.substeps}: give a positive count")
    base = load(None, args.sets)
    for scheme in args.schemes:
        cfg = with_sets(base, [f"plant.step_scheme={scheme}", f"plant.substeps={args.substeps}"])
        print(f"\n## {scheme}, {args.substeps} substep(s), F_N1 = {args.fn1:g} N: stuck poles against h / 64\n")
        pole_table(cfg, args.fn1)
    return 0


if __name__ == "__main__":
    run_main(main)
