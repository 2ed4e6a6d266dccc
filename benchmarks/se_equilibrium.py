"""Which coarsened interfaces of the 3-D reference (plant.fe3d, 57 contact points) have a static
equilibrium under the bolts, and the reason of those that have none (plant.se_plant.no_equilibrium_reason).

    python -m benchmarks.se_equilibrium [--clusters 1,2,3,4,6,8,16] [--dims 2,1] [--mesh reference|coarse]

Per cluster count and friction dimension (1-D: the second tangential row dropped, as
benchmarks/superelement_reference.py does), the plant is built at the configured preload
(``build_se_plant(se, Config())``) and the result printed: "holds" or the one-line refusal.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

COARSE = {"interface_pitch_m": 0.04, "pitch_m": 0.05, "cutoff_hz": 4000.0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clusters", default="1,2,3,4,6,8,16")
    ap.add_argument("--dims", default="2,1")
    ap.add_argument("--mesh", choices=("reference", "coarse"), default="reference")
    a = ap.parse_args(argv)
    from frictionrt.plant import fe3d
    from frictionrt.plant import superelement as S
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.rt.common.config import Config
    cfg = Config()
    se, _ = fe3d.reference_superelement(cfg, **(COARSE if a.mesh == "coarse" else {}))
    for nt in (int(x) for x in a.dims.split(",")):
        for c in (int(x) for x in a.clusters.split(",")):
            sek = S.coarsen(se, c)
            s = sek if nt == 2 else sek.with_(contact_rows=np.ascontiguousarray(sek.contact_rows[:, :2]))
            t = time.process_time()
            try:
                build_se_plant(s, cfg)
                r = "holds"
            except RuntimeError as e:
                r = str(e)
            print(f"{c:>3} points, {nt}-D friction ({time.process_time() - t:.1f} s CPU): {r}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
