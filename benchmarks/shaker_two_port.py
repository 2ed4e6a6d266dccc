"""The voltage-driven shaker on FRF files per drive volt, diagnosed: the full workflow (calibration,
the structural candidates and the shaker's two-port, ranked) on rig truths whose excitation is a
voltage-mode shaker at the drive point (docs/studies/shaker-two-port.md).

    python -m benchmarks.shaker_two_port [--cases default lap_joint_al] [--seeds 0 1] [--json]

Per case (structure, the FRF files a lab has) and truth (the shaker at its catalogue values, the
nominal's: armature 0.1 kg, Bl 10 N/A, R 1.5 ohm, c_e = Bl^2 / R = 66.7 N s/m; and off them: 0.15 kg,
Bl 12 N/A, 96 N s/m, which the diagnosis, starting from the catalogue, has to find) and seed: the named
effect, the fitted armature mass and c_e against the truth, the force scale [N/V], the gap before /
calibrated / after [dB] and the wall time (one BLAS thread, as the diagnosis runs). Done when the
shaker is named with both within 20 %.
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from frictionrt.rt.common.config import Config, load, with_sets
from frictionrt.rt.discrepancy.diagnose.frf import BACK_EMF, SHAKER, diagnose_frf
from frictionrt.rt.discrepancy.rig.frf import make_frf_campaign
from benchmarks.entry import run_main

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
# case: (nominal, make_frf_campaign's file kinds)
CASES = {
    "default": (lambda: with_sets(Config(), []), {"force_scale_N_per_V": 10.0}),
    "lap_joint_al": (lambda: load(CONFIGS / "lap_joint_al.toml"),      # the lab: a laser's mobility at the tip
                     {"force_scale_N_per_V": 0.37, "quantity": "mobility", "sensors": {"v_tip_laser": ("B", 0.4892)}}),
}
TRUTHS = {"catalogue": (0.1, 10.0), "off_catalogue": (0.15, 12.0)}   # (armature mass [kg], Bl [N/A])
REL = 0.2


def run_case(case: str, truth: str, seed: int) -> dict:
    make_nominal, kinds = CASES[case]
    nominal = make_nominal()
    m, Bl = TRUTHS[truth]
    cfg = with_sets(nominal, ["shaker.amplifier=voltage", f"shaker.force_constant_N_per_A={Bl!r}"])
    c_e = Bl ** 2 / cfg.shaker.coil_resistance_ohm
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "frf"
        make_frf_campaign(d, SHAKER, m, seed=seed, cfg=cfg, **kinds)
        t = time.perf_counter()
        res = diagnose_frf(d, nominal)
        wall = time.perf_counter() - t
    th = next((r["fitted"] for r in res["ranking"] if r["effect"] == SHAKER), {})
    m_fit, c_fit = th.get(SHAKER, float("nan")), th.get(BACK_EMF, float("nan"))
    ok = res["named_effect"] == SHAKER and abs(m_fit / m - 1) <= REL and abs(c_fit / c_e - 1) <= REL
    return {"case": case, "truth": truth, "seed": seed, "named": res["named_effect"],
            "runner_up": res["runner_up"], "mass_kg": [m, m_fit], "back_emf_Ns_per_m": [round(c_e, 3), c_fit],
            "force_scale_N_per_V": [kinds["force_scale_N_per_V"], th.get("force_scale_N_per_V")],
            "gap_db": [res[k]["structure_frf_db"] for k in ("gap_before", "gap_calibrated", "gap_after")],
            "delta_bic": next((r["delta_bic"] for r in res["ranking"] if r["effect"] == SHAKER), None),
            "wall_s": round(wall, 1), "done": ok}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    p.add_argument("--truths", nargs="+", choices=list(TRUTHS), default=list(TRUTHS))
    p.add_argument("--seeds", nargs="+", type=int, default=[0])
    p.add_argument("--json", action="store_true")
    a = p.parse_args()
    rows = []
    for case in a.cases:
        for truth in a.truths:
            for seed in a.seeds:
                r = run_case(case, truth, seed)
                rows.append(r)
                if not a.json:
                    print(f"{case:13s} {truth:13s} seed {seed}: named {r['named']}, m {r['mass_kg'][1]:.4g} kg "
                          f"(truth {r['mass_kg'][0]:g}), c_e {r['back_emf_Ns_per_m'][1]:.4g} N s/m (truth "
                          f"{r['back_emf_Ns_per_m'][0]:g}), s {r['force_scale_N_per_V'][1]} N/V, gap "
                          f"{' / '.join(f'{g:.2f}' for g in r['gap_db'])} dB, dBIC {r['delta_bic']}, "
                          f"{r['wall_s']} s, {'done' if r['done'] else 'NOT done'}", flush=True)
    if a.json:
        print(json.dumps(rows, indent=1))
    return 0 if all(r["done"] for r in rows) else 1


if __name__ == "__main__":
    run_main(main)
