"""The built-in 2-D beam plant against the 3-D reference superelement (plant.fe3d): the hammer test
at F_N1 = 100 N (natural frequencies and damping of modes 2-5) and the passive law's step-sine
peaks (frequency and |H| of modes 2-5 at 5 and 20 N), both plants in the same closed loop.

    python -m benchmarks.se_2d_vs_3d [--clusters 16] [--clustering footprint|coordinates] [--hammer-clusters 0]
                                     [--modes 2,3,4,5] [--amps 5,20] [--mesh reference|coarse] [--set KEY=VALUE]
                                     [--json OUT.json]

The hammer test runs the plant alone (plant.impulse's pulse and fit; plant.se_analysis.impulse on
the superelement, its interface coarsened to --hammer-clusters points, 0: the 57 points as built).
The step-sine peak of a mode is found as ``compare --mode`` finds it
(rt.experiments.compare.passive_peak_hz: ``reproduce --quick``'s grid of 9 points over the mode's
band and 2 refinement rounds, each point settled to 2 % or 2 s) in the closed loop with the passive
law (F_N1 held at tracking.F_passive_N) and the oracle estimator (the passive law does not read it),
the superelement's interface coarsened to --clusters points by --clustering (plant.se_coarsen; the closed loop on the 57-point
interface costs about 5 ms a tick: docs/studies/superelement-3d.md, section 3). The 3-D modes are
counted as the laws see them (rt.experiments.stepsine.structure_mode_bands_hz): its lateral and
torsion modes are skipped. --mesh coarse: the test suite's small model (39 points), for a quick
check of the script.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np
from benchmarks.entry import run_main, write_json

COARSE = {"interface_pitch_m": 0.04, "pitch_m": 0.05, "cutoff_hz": 4000.0}


def peak(loop, mode: int, amp_n: float, designs) -> tuple[float, float]:
    """(f [Hz], |H| [(m/s^2)/N]) of the passive step-sine peak of ``mode`` at ``amp_n`` [N]
    (rt.experiments.compare.passive_peak_hz's search, the peak's |H| kept)."""
    from frictionrt.rt.experiments.reproduce import HALF_WIDTH, QUICK, merge, refine_points
    from frictionrt.rt.experiments.stepsine import mode_bands_hz, resonance_grid, sweep
    lo, hi = mode_bands_hz(loop.cfg, (mode,), designs, loop.structure)[mode]
    r = sweep(loop, resonance_grid([0.5 * (lo + hi)], HALF_WIDTH.get(mode, 0.15), QUICK.n_points), amp_n,
              settle=QUICK.settle)
    for _ in range(QUICK.refine_rounds):
        new = refine_points(r.freq_hz, r.H_abs)
        if not new:
            break
        r = merge([r, sweep(loop, new, amp_n, settle=QUICK.settle)])
    k = int(np.argmax(r.H_abs))
    return float(r.freq_hz[k]), float(r.H_abs[k])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clusters", type=int, default=16, help="the step-sine's 3-D interface points (0: as built)")
    ap.add_argument("--clustering", default="footprint", help="how --clusters and --hammer-clusters group the points")
    ap.add_argument("--hammer-clusters", type=int, default=0, help="the hammer test's 3-D interface points")
    ap.add_argument("--modes", default="2,3,4,5")
    ap.add_argument("--amps", default="5,20", help="step-sine force amplitudes [N]")
    ap.add_argument("--mesh", choices=("reference", "coarse"), default="reference")
    ap.add_argument("--no-stepsine", action="store_true", help="the hammer test only")
    ap.add_argument("--no-hammer", action="store_true", help="the step-sine peaks only")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a configuration override for both plants (e.g. plant.newton_max_iter=200)")
    ap.add_argument("--json", metavar="OUT.json")
    a = ap.parse_args(argv)
    from frictionrt import jobs
    from frictionrt.plant import fe3d
    from frictionrt.plant import superelement as S
    from frictionrt.plant.se_analysis import impulse as se_impulse
    from frictionrt.plant.se_coarsen import coarsen_structure
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.rt.common.config import Config, with_sets
    from frictionrt.rt.loop import Designs, build_loop
    from frictionrt.rt.loop.structure import structure_of
    import tempfile
    modes = [int(m) for m in a.modes.split(",")]
    amps = [float(x) for x in a.amps.split(",")]
    cfg = with_sets(Config(), a.set)
    out: dict = {"load_avg_start": os.getloadavg()[0], "modes": modes, "amps_n": amps, "sets": a.set}
    t0 = time.perf_counter()
    se, info = fe3d.reference_superelement(cfg, **(COARSE if a.mesh == "coarse" else {}))
    out["n_points"] = se.n_points
    print(f"3-D reference: {se.n} DOFs, {se.n_points} contact points ({time.perf_counter() - t0:.0f} s)")

    # --- hammer test at F_N1 = 100 N
    if not a.no_hammer:
        F = 100.0
        h2 = jobs.impulse(cfg, fn1_n=F).to_dict()
        two = {int(m): (f, z) for m, f, z in zip(h2["modes"], h2["freq_hz"], h2["damping_ratio"])}
        seh = coarsen_structure(se, a.hammer_clusters, cfg, a.clustering)
        t = time.perf_counter()
        h3 = se_impulse(build_se_plant(seh, cfg), cfg, F, n_modes=len(modes))
        out["hammer_3d_s"] = time.perf_counter() - t
        rows = []
        print(f"hammer test, F_N1 = {F:g} N, {cfg.impulse.peak_N:g} N pulse: 2-D beams | 3-D {seh.n_points} points "
              f"({out['hammer_3d_s']:.0f} s)")
        print(f"{'mode':>4} {'2-D f [Hz]':>10} {'3-D f [Hz]':>10} {'diff [%]':>9} {'2-D zeta [%]':>12} {'3-D zeta [%]':>12}")
        for m, f3, z3 in zip(modes, h3["freq_hz"], h3["damping_ratio"]):
            f2, z2 = two[m]
            rows.append({"mode": m, "f2_hz": f2, "f3_hz": f3, "zeta2": z2, "zeta3": z3})
            print(f"{m:>4} {f2:>10.2f} {f3:>10.2f} {100 * (f2 / f3 - 1):>+9.2f} {100 * z2:>12.3f} {100 * z3:>12.3f}")
        out["hammer"] = {"F_N1_N": F, "points": seh.n_points, "rows": rows, "linear_3d_hz": h3["linear_hz"]}

    # --- passive step-sine peaks
    if not a.no_stepsine:
        with tempfile.TemporaryDirectory() as d:
            f = S.save(coarsen_structure(se, a.clusters, cfg, a.clustering), os.path.join(d, "se.npz"))
            st = structure_of(f)
            rows = []
            loops = {}
            for name, structure in (("2-D", None), ("3-D", st)):
                designs = Designs()
                loops[name] = (build_loop(cfg, "passive", "oracle", designs=designs, structure=structure), designs)
            print(f"passive step-sine peaks: 2-D beams | 3-D {a.clusters or se.n_points} points")
            print(f"{'mode':>4} {'F [N]':>5} {'2-D f [Hz]':>10} {'3-D f [Hz]':>10} {'diff [%]':>9} "
                  f"{'2-D |H|':>9} {'3-D |H|':>9} {'diff [dB]':>9}")
            for m in modes:
                for amp in amps:
                    r = {"mode": m, "amp_n": amp}
                    for name, (loop, designs) in loops.items():
                        t = time.perf_counter()
                        r[name] = peak(loop, m, amp, designs)
                        r[name + "_s"] = time.perf_counter() - t
                    (f2, H2), (f3, H3) = r["2-D"], r["3-D"]
                    rows.append(r)
                    print(f"{m:>4} {amp:>5g} {f2:>10.2f} {f3:>10.2f} {100 * (f2 / f3 - 1):>+9.2f} {H2:>9.3g} "
                          f"{H3:>9.3g} {20 * np.log10(H2 / H3):>+9.2f}   ({r['2-D_s']:.0f} s, {r['3-D_s']:.0f} s)",
                          flush=True)
            out["stepsine"] = {"points": a.clusters or se.n_points, "clustering": a.clustering, "rows": rows}
    out["load_avg_end"] = os.getloadavg()[0]
    out["wall_s"] = time.perf_counter() - t0
    write_json(a.json, out)
    return 0


if __name__ == "__main__":
    run_main(main)
