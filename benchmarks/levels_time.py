"""The cost of ``diagnose --calibrate-on`` at a lab's resolution, with describing functions and with AFT
(docs/discrepancy.md "Amplitude dependence"): six drive-voltage levels of 1,600 lines each.

    python -m benchmarks.levels_time [--method df aft] [--levels 0.5 1 2 5 10 20] [--folder DIR] [--json OUT]

The data: configs/lap_joint_al.toml's true structure (the rig's scatter draw of seed 3, micro_slip hidden at its
default spread 0.5), mode 2's region 80-180 Hz on 1,600 lines of 0.0625 Hz (a lab's 16 s blocks), the harmonic
balance (df) of that truth at each drive amplitude V x 0.37 N/V at the tip accelerometer, as mobility per volt
(a laser at the tip, no force transducer), with the FRF files' noise (rt.discrepancy.rig.frf: 1 % of |H| plus
the floor), one file per level (sidecar excitation drive_voltage, drive_amplitude_v). Not a simulation of the
time-stepped plant (the rig's stepped sines on 1,600 lines would take hours): what is measured is the
diagnosis's cost on the lab's line count and its workflow, so the truth's own df model is the data, as for the
earlier measurement of 32.5 s.

Then ``diagnose_levels`` calibrated on the two lowest levels, once per ``--method``: its process CPU time, wall
time, the model evaluations of the harmonic balance's fits and where the prediction lands.
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from frictionrt.plant.harmonic_frf import harmonic_system
from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import load
from frictionrt.rt.discrepancy.chain import quiet
from frictionrt.rt.discrepancy.diagnose.levels import diagnose_levels
from frictionrt.rt.discrepancy.diagnose.random_level import level_accelerances
from frictionrt.rt.discrepancy.rig import true_structure
from frictionrt.rt.discrepancy.rig.frf import NOISE_FLOOR, NOISE_REL, frf_meta, sensor_points
from frictionrt.rt.log.frf_files import FRFTest, from_accelerance, write_frf_csv, write_frf_uff
from benchmarks.entry import run_main

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "lap_joint_al.toml"
SCALE = 0.37                                    # [N/V] the shaker's force per drive volt
LINES = 80.0 + 0.0625 * np.arange(1600)         # [Hz] 80 .. 179.9375 Hz
SENSOR = "a_tip_meas"


def write_levels(folder: Path, levels, seed: int = 3) -> None:
    """The six levels' files (module docstring) into the new folder ``folder``."""
    cfg = load(CONFIG)
    rng = np.random.default_rng(seed)
    true = true_structure(cfg, "micro_slip", None, rng)
    point = sensor_points(true)[SENSOR]
    hs = harmonic_system(build_plant(quiet(true)), {SENSOR: point}, F_N1=0.0)
    folder.mkdir(parents=True)
    for j, v in enumerate(sorted(levels)):
        h = level_accelerances(hs, float(v), SCALE, LINES, method="df", branches=False).H[SENSOR]
        z, w = rng.standard_normal((2, len(h), 2)) @ np.array([1.0, 1j]) / np.sqrt(2)
        H = {SENSOR: SCALE * from_accelerance(h * (1.0 + NOISE_REL * z) + NOISE_FLOOR * w, LINES, "mobility")}
        meta = frf_meta(true, 0.0, f"stepped sine, shaker driven at {v:g} V amplitude, no force transducer, "
                        "laser at the tip", {SENSOR: point}, quantity="mobility", excitation="drive_voltage") | {
                            "amplitude_n": None, "drive_amplitude_v": float(v)}
        name = f"level_{j + 1:02d}" + (".uff" if j % 2 else ".csv")
        (write_frf_uff if j % 2 else write_frf_csv)(folder / name, FRFTest(Path(name).stem, LINES, H, None, None, meta))


def run(folder: Path, levels, method: str) -> dict:
    cfg = load(CONFIG)
    lv = sorted(levels)
    t, w = time.process_time(), time.perf_counter()
    res = diagnose_levels(folder, lv[:2], cfg, method=method)
    cpu, wall = time.process_time() - t, time.perf_counter() - w
    top = next(p for p in res["prediction"] if p["level_n"] == lv[-1])
    return {"method": method, "cpu_s": round(cpu, 1), "wall_s": round(wall, 1), "load": os.getloadavg()[0],
            "evaluations": res["nonlinear"]["evaluations"], "lines": res["nonlinear"]["lines"],
            "named": res["named_effect"], "ranking": res["ranking"], "calibration_gap": res["calibration_gap"],
            "fitted": res["nonlinear"]["fitted"], "linear": res["linear"]["fitted"],
            "top": {k: top.get(k) for k in ("level_n", "gap_linear_db", "gap_nonlinear_db", "ratio", "gap_aft_db")}}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", nargs="+", default=["df", "aft"], choices=("df", "aft"))
    ap.add_argument("--levels", type=float, nargs="+", default=[0.5, 1.0, 2.0, 5.0, 10.0, 20.0])
    ap.add_argument("--folder", default=None, help="an existing folder of the levels, else a new temporary one")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    folder = Path(a.folder) if a.folder else Path(tempfile.mkdtemp()) / "levels"
    if not folder.exists():
        write_levels(folder, a.levels)
    out = {"folder": str(folder), "levels_v": sorted(a.levels), "lines_per_level": len(LINES),
           "runs": [run(folder, a.levels, m) for m in a.method]}
    text = json.dumps(out, indent=1)
    print(text)
    if a.json:
        Path(a.json).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    run_main(main)
