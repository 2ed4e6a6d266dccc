"""The contact Newton's iterations per tick of the loop on a coarsened imported structure.

    python -m benchmarks.se_newton_tail [--clusters 6] [--clustering footprint] [--seconds 5]
        [--law lyapunov] [--freq-hz 223.6] [--amp-n 5] [--json OUT.json]

The 57-point 3-D reference (plant.fe3d) coarsened by --clustering (plant.se_coarsen), the closed loop
of --law on the observer designed from it, offline for --seconds at the excitation (default the tick
budget's, rt.loop.budget), with plant.newton_max_iter = 200 so that no tick fails: the Newton
iterations per tick (max, p99.9, p99, mean) and the ticks above the default limit of 40.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np
from benchmarks.entry import run_main, write_json


def main(argv=None) -> int:
    from frictionrt.rt.loop.budget import EXC_AMP_N, EXC_FREQ_HZ
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clusters", type=int, default=6)
    ap.add_argument("--clustering", default="footprint")
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--law", default="lyapunov")
    ap.add_argument("--freq-hz", type=float, default=EXC_FREQ_HZ)
    ap.add_argument("--amp-n", type=float, default=EXC_AMP_N)
    ap.add_argument("--json", metavar="OUT.json")
    a = ap.parse_args(argv)
    from frictionrt.plant import fe3d
    from frictionrt.plant import superelement as S
    from frictionrt.plant.se_coarsen import coarsen_structure
    from frictionrt.rt.common.config import Config, with_sets
    from frictionrt.rt.common.kernel_version import KERNEL_VERSION
    from frictionrt.rt.loop import build_loop
    from frictionrt.rt.loop.driver import run
    from frictionrt.rt.loop.structure import structure_of
    cfg = with_sets(Config(), ["plant.newton_max_iter=200"])
    se, _ = fe3d.reference_superelement(cfg)
    with tempfile.TemporaryDirectory() as d:
        f = S.save(coarsen_structure(se, a.clusters, cfg, a.clustering), os.path.join(d, "s.npz"))
        loop = build_loop(cfg, a.law, "observer", structure=structure_of(f, 0, a.clustering))
        t0 = time.perf_counter()
        it = np.asarray(run(loop, a.freq_hz, a.amp_n, a.seconds).signal("newton_iter"))
    out = {"kernel_version": KERNEL_VERSION, "clusters": a.clusters, "clustering": a.clustering, "law": a.law,
           "freq_hz": a.freq_hz, "amp_n": a.amp_n, "ticks": int(it.size), "max": int(it.max()),
           "p999": float(np.percentile(it, 99.9)), "p99": float(np.percentile(it, 99)), "mean": float(it.mean()),
           "over_40": int((it > 40).sum()), "first_over_40": np.flatnonzero(it > 40)[:10].tolist(),
           "wall_s": round(time.perf_counter() - t0, 1), "load_avg": os.getloadavg()[0]}
    print(f"{a.clusters} points ({a.clustering}), {a.law}, {a.amp_n:g} N at {a.freq_hz:g} Hz, {it.size} ticks "
          f"(kernel version {KERNEL_VERSION}): Newton iterations max {out['max']}, p99.9 {out['p999']:g}, p99 "
          f"{out['p99']:g}, mean {out['mean']:.2f}; {out['over_40']} ticks over 40 {out['first_over_40']} "
          f"({out['wall_s']} s wall, load {out['load_avg']:.1f})")
    write_json(a.json, out)
    return 0


if __name__ == "__main__":
    run_main(main)
