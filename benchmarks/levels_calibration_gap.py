"""The level diagnosis's two models at their calibration levels on the suite's level-test campaigns
(docs/discrepancy.md "Amplitude dependence"): is the harmonic balance's gap there no larger than the linear
model's?

    python -m benchmarks.levels_calibration_gap [--case suite suite-aft lap lap-aft] [--json OUT]

Cases, the campaigns of the suite's level tests (the same rig calls, seeds and bands):

* ``suite``: tests/test_diagnose_levels.py's folder: the default structure, no hidden effect, seed 3, mode 3's
  band 190-270 Hz, drive voltages 1.35, 2.7, 27 V at 0.37 N/V; calibrated on 1.35 and 2.7 V, df;
* ``suite-aft``: the same, ``--harmonic-method aft``;
* ``lap``: tests/test_levels_aft.py's campaign: configs/lap_joint_al.toml, micro_slip hidden, seed 3, mode 2's
  band 100-150 Hz, 1 and 10 N; calibrated on 1 N, df;
* ``lap-aft``: the same, aft.

Per case: the calibration gap (the rms of the weighted residuals over the modes' bands at the calibration
levels, the objective both models are fitted on; 1 = the noise), linear and harmonic balance, whether the
harmonic balance was refused (then the stuck limit, the linear model, is kept), and the gaps [dB] per level in the
softening band and over all lines, with the process's CPU time.
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from frictionrt.rt.common.config import Config, load, with_sets
from frictionrt.rt.discrepancy.diagnose.levels import diagnose_levels
from frictionrt.rt.discrepancy.rig.levels import make_level_campaign
from benchmarks.entry import run_main

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGNS = {   # name -> (configuration, effect, seed, levels, band [Hz], force scale [N/V] or None, calibrate on)
    "suite": (None, "none", 3, (1.35, 2.7, 27.0), (190.0, 270.0), 0.37, (1.35, 2.7)),
    "lap": (ROOT / "configs" / "lap_joint_al.toml", "micro_slip", 3, (1.0, 10.0), (100.0, 150.0), None, (1.0,)),
}
CASES = {"suite": ("suite", "df"), "suite-aft": ("suite", "aft"), "lap": ("lap", "df"), "lap-aft": ("lap", "aft")}


def run_case(case: str, folders: dict) -> dict:
    name, method = CASES[case]
    cfg_path, effect, seed, levels, band, scale, cal = CAMPAIGNS[name]
    cfg = load(cfg_path) if cfg_path else with_sets(Config(), [])
    if name not in folders:
        folders[name] = Path(tempfile.mkdtemp()) / name
        make_level_campaign(folders[name], effect, seed=seed, cfg=cfg, force_levels_n=levels, band_hz=band,
                            force_scale_N_per_V=scale)
    t = time.process_time()
    res = diagnose_levels(folders[name], list(cal), cfg, method=method)
    rows = [{k: p.get(k) for k in ("level_n", "calibrated_on", "gap_linear_db", "gap_nonlinear_db",
                                   "gap_linear_all_db", "gap_nonlinear_all_db")} for p in res["prediction"]]
    return {"case": case, "method": method, "calibrate_on": list(cal), "calibration_gap": res["calibration_gap"],
            "named": res["named_effect"], "levels": rows, "cpu_s": round(time.process_time() - t, 1),
            "load": os.getloadavg()[0]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    folders: dict = {}
    out = []
    for c in a.case:
        out.append(run_case(c, folders))
        print(json.dumps(out[-1]), flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    run_main(main)
