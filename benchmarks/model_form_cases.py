"""Model-form cases of the FRF-file diagnosis (docs/discrepancy.md "Model-form candidates"): a truth with
a compliant clamp and a compliant joint together, written as FRF files by the virtual rig, diagnosed
with the nominal model.

    python -m benchmarks.model_form_cases [--clamp 3e-4] [--joint 0.003] [--clamp-heights 15]
                                          [--levels 40 100 300] [--seed 5] [--json OUT]

Case (b): the clamp's rotational compliance ``--clamp`` [rad/(N m)] and the joint's stiffness
``--joint`` (x the contact model's k_n_area, k_t_area) in the truth (its scatter and FRF noise of
rt.discrepancy.rig.frf, seed ``--seed``), mode 2 at 100 N shifted by the printed amount against the
nominal. The nominal says how compliant its fixture may be: ``--clamp-heights`` (diagnosis.uncertainty.
clamp_heights: a soft bench vice, 15 beam heights of extra beam, 6.7e-5 x 5 = 3.4e-4 rad/(N m) on the
benchmark's beam; the default 3 would hold the clamp at 6.7e-5). Reported: the truth's mode shifts, what the localisation points at, the named candidates
(first and second round), their fitted strengths against the truth, E against the truth's E (the
scatter draw), the gap before and after, and the CPU time of the diagnosis.
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.discrepancy.diagnose.frf import diagnose_frf
from frictionrt.rt.discrepancy.effects import get
from frictionrt.rt.discrepancy.rig import scatter_sets
from frictionrt.rt.discrepancy.rig.frf import make_frf_campaign
from benchmarks.entry import run_main


def truth(clamp: float, joint: float, base: Config | None = None) -> Config:
    """The nominal (``base``, default the default configuration) with the clamp's rotational compliance and the
    joint's stiffness ratio of case (b) (no scatter)."""
    cfg = base if base is not None else with_sets(Config(), [])
    return get("joint_compliance").apply(get("clamp_compliance").apply(cfg, clamp), joint)


def shifts(cfg: Config, nominal: Config, F_N1: float = 100.0, n: int = 8) -> list[float]:
    """Relative shifts of the first n stuck frequencies at F_N1 [N] of ``cfg`` against ``nominal``."""
    def f(c):
        m = build_plant(c)
        return stuck_frequencies_hz(m, preloaded_pairs(m, F_N1))[:n]
    return [round(float(x), 4) for x in f(cfg) / f(nominal) - 1.0]


def case_b(clamp: float, joint: float, levels, seed: int, clamp_heights: float = 15.0) -> dict:
    nominal = with_sets(Config(), [f"diagnosis.uncertainty.clamp_heights={clamp_heights!r}"])
    d = Path(tempfile.mkdtemp()) / "case_b"
    base = get("clamp_compliance").apply(nominal, clamp)
    make_frf_campaign(d, "joint_compliance", joint, seed=seed, cfg=base, levels_n=tuple(levels))
    E_true = scatter_sets(np.random.default_rng(seed))["E"]
    t = time.process_time()
    res = diagnose_frf(d, nominal)
    cpu = time.process_time() - t
    fitted = res["fitted_parameters"]
    return {"clamp_true": clamp, "joint_true": joint, "levels": list(levels), "seed": seed,
            "clamp_heights": clamp_heights,
            "truth_shifts_100N": shifts(truth(clamp, joint), nominal),
            "points_at": res["where"]["points_at"], "where_top": res["where"]["parameters"][:4],
            "named": res["named"], "model_form_named": res["model_form"]["named"],
            "ranking": [(r["effect"], r["delta_bic"], r["rss_reduction"], r["fitted"]) for r in res["ranking"]],
            "second_round": res.get("second_round"), "fitted": fitted,
            "E_true": round(E_true, 5), "E_error": round(fitted["E"] / E_true - 1.0, 5),
            "clamp_error": (round(fitted["clamp_compliance"] / clamp - 1.0, 4) if "clamp_compliance" in fitted else None),
            "joint_error": (round(fitted["joint_compliance"] / joint - 1.0, 4) if "joint_compliance" in fitted else None),
            "gap_db": [res["gap_before"]["structure_frf_db"], res["gap_calibrated"]["structure_frf_db"],
                       res["gap_after"]["structure_frf_db"]],
            "plausibility": res["plausibility"]["note"], "cpu_s": round(cpu, 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clamp", type=float, default=3e-4)
    ap.add_argument("--joint", type=float, default=0.003)
    ap.add_argument("--clamp-heights", type=float, default=15.0)
    ap.add_argument("--levels", type=float, nargs="+", default=[40.0, 100.0, 300.0])
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    out = case_b(a.clamp, a.joint, a.levels, a.seed, a.clamp_heights)
    text = json.dumps(out, indent=1)
    print(text)
    if a.json:
        Path(a.json).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    run_main(main)
