"""Step-sine FRF tests of the virtual rig (``frictionrt rig --stepsine``, docs/discrepancy.md):
passive (the stack holds a constant F_N1), force amplitude held by the amplitude controller of
rt.experiments.stepsine, one up-sweep per (F_N1 level, force amplitude), written as FRF files (rt.log.frf_files:
CSV + JSON sidecar) ``stepsine_NN.csv``.

Lines (``LINES_HZ``, the same for every campaign): 6 around mode 3 (185-230 Hz: the nominal slip
and stuck frequencies 198.4 and 223.6 Hz at 100 N, rt.experiments.stepsine.mode_bands_hz), 6 around mode 4
(355-400 Hz: 369.0, 388.8 Hz) and a coarse grid elsewhere (120, 300, 500, 700, 1100, 1250 Hz: away
from the a_frf antiresonances at 880 and 1040 Hz, where the model's R_exc / H of the diagnosis is
ill-conditioned; 1250 Hz near the armature-on-stinger resonance of a 0.1 kg shaker), at
``AMPLITUDES_N`` and every F_N1 level of the campaign. Per line the file holds the accelerances of
both accelerometers (their readings through plant.sensors over the measured force), the measured
force amplitude F_amp_N and the drive amplitude drive_amp_N (the force an ideal source would give
for the shaker's command). A line that did not settle within ``SETTLE.max_s`` is left out, as a
lab would repeat or drop it. The loop's force is noise-free; F_amp_N gets the force transducer's
noise as its first-harmonic fit would: FORCE_NOISE_N sqrt(2 / n) over the n samples of the final
blocks (3.7e-4 N at 6000 samples: relative 4e-5-7e-5 at 5-10 N).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.log.frf_files import FORMAT, FRFTest, write_frf_csv
from frictionrt.rt.discrepancy.chain import FORCE_NOISE_N
from frictionrt.rt.experiments.branches import Branch, run_branches
from frictionrt.rt.experiments.stepsine import SENSOR_READINGS, Settle

AMPLITUDES_N = (5.0, 10.0)                   # target force amplitudes [N]
LINES_HZ = tuple(sorted({120.0, 300.0, 500.0, 700.0, 1100.0, 1250.0}
                        | set(np.linspace(185.0, 230.0, 6).tolist())
                        | set(np.linspace(355.0, 400.0, 6).tolist())))
SETTLE = Settle(max_s=1.5)                   # a line gives up after 1.5 s (default 8 s; cost)


def branches(true: Config, levels_n, seed: int) -> list[Branch]:
    """One up-sweep per (F_N1 level, amplitude): the passive law at F_passive_N = level."""
    out = []
    for j, fn1 in enumerate(levels_n):
        cfg = with_sets(true, [f"tracking.F_passive_N={float(fn1)!r}"])
        for i, amp in enumerate(AMPLITUDES_N):
            out.append(Branch(cfg, "passive", amp, LINES_HZ, settle=SETTLE,
                              seed=seed * 1000 + 200 + len(AMPLITUDES_N) * j + i))
    return out


def write_stepsine_tests(folder: Path, true: Config, levels_n, seed: int, jobs: int | None = None) -> list[str]:
    """Run the step-sine tests of the campaign on the true configuration and write them into
    ``folder``; returns the file names written (the sidecars beside them)."""
    bs = branches(true, levels_n, seed)
    results = run_branches(bs, jobs=jobs, progress=False, desc="rig step-sine")
    pts = {p.name: p.x_m for p in true.plant.points}
    sensors = {"a_frf_meas": pts[true.plant.frf_point], "a_tip_meas": pts["tip"]}
    names = []
    for j, (b, r) in enumerate(zip(bs, results)):
        ok = r.settled
        rng = np.random.default_rng(b.seed + 100)
        n = np.array([SETTLE.n_blocks * SETTLE.block_ticks(f, true.dt_s) for f in r.freq_hz])
        F_amp = r.F_amp + FORCE_NOISE_N * np.sqrt(2.0 / n) * rng.standard_normal(len(n))
        if ok.sum() < 2:
            continue
        meta = {"format": FORMAT, "kind": "stepsine", "excitation_x_m": pts[true.plant.excitation_point],
                # the stack's set force (held voltage); the bolt's mean force adds its response to the
                # beams' separation (docs/plant.md 1.4), which the model reproduces from the set force
                "sensor_positions_m": sensors, "F_N1_N": float(b.cfg.tracking.F_passive_N),
                "amplitude_n": float(b.amp_n),
                "description": f"step-sine up-sweep, adaptive screw held at about {b.cfg.tracking.F_passive_N:g} N "
                               f"by the stack (passive), force amplitude held at {b.amp_n:g} N; lines that did not "
                               f"settle within {SETTLE.max_s:g} s left out"}
        stem = f"stepsine_{j + 1:02d}"
        write_frf_csv(folder / f"{stem}.csv", FRFTest(
            stem, r.freq_hz[ok], {s: r.H_sensors[s][ok] for s in SENSOR_READINGS}, F_amp[ok], r.drive_amp[ok], meta))
        names.append(f"{stem}.csv")
    return names
