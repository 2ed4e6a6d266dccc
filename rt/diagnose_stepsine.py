"""The step-sine channel of the diagnosis (docs/discrepancy.md): the shaker's force ratio.

Data: the step-sine FRF files of a campaign folder (rt.frf_files, kind "stepsine", with the columns
F_amp_N and drive_amp_N): per line the measured ratio rho = F_amp / drive. The nominal model's
shaker is an ideal force source, rho = 1.

Model of the candidate ``shaker_interaction`` (armature mass m; the shaker's other constants at
their catalogue values, rt.config.Shaker): the two-port of ``rt.shaker.force_ratio``,

    F_exc / drive = 1 / (1 + D_a / k~ + D_a R),

with the structure's driving-point receptance R = w_exc / F_exc at the line estimated as

    R = H_meas * (R_exc / H)_model,

H_meas the measured accelerance a_frf_meas / F_exc, and the bracket the ratio of the two responses
in the calibrated model's own step-sine (ideal source, the test's F_N1, force amplitude and lines:
rt.stepsine, ``R_exc`` and ``H_sensors``): the same amplitude-dependent (slipping) vibration seen at
the excitation point and at the accelerometer. The stuck linear structure is no substitute there:
near the friction-affected resonances (mode 3 at 200 Hz instead of the stuck 224 Hz at 100 N, 10 N)
the measured accelerance differs from the stuck one by factors 0.04-4.5 and the two-port on the stuck
driving point missed the measured ratio by up to 60 % (0.42 measured, 1.01 predicted at 200 Hz).
Since the shaker leaves a / F_exc unchanged (the force is measured at the structure), the model
needs no shaker for R: one ideal-source simulation per diagnosis, then the fit of m is closed-form
(a grid, then a bounded scalar minimisation).

Residuals (ln |rho_meas| - ln |rho_model|) / ``SIGMA`` per line, channel "stepsine F_amp/drive".
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from rt.config import Config, with_sets
from rt.effects import Effect
from rt.frf_files import FRFTest, frf_files, load_frf_folder
from rt.rig import quiet
from rt.shaker import force_ratio
from rt.stepsine import Branch, Settle, run_branches

CHANNEL = "stepsine F_amp/drive"
SIGMA = 0.01             # [-] relative: the scale of the residuals (BIC per channel does not depend on it)
MODEL_SETTLE = Settle(max_s=1.0, rel_tol=0.02)   # the model's lines: a ratio of two responses settles fast


class StepsineData(NamedTuple):
    tests: list[FRFTest]
    freq: list[np.ndarray]        # per test: lines [Hz]
    rho: list[np.ndarray]         # measured F_amp / drive [-]
    R: list[np.ndarray]           # estimated driving-point receptance [m/N] (complex)


def load_stepsine(folder: str | Path) -> list[FRFTest]:
    """The step-sine tests with force and drive amplitudes in the folder (none: [])."""
    if not frf_files(folder):
        return []
    return [t for t in load_frf_folder(folder)
            if t.meta["kind"] == "stepsine" and t.F_amp_N is not None and t.drive_amp is not None
            and t.meta["amplitude_n"] is not None and "a_frf_meas" in t.H]


def model_branches(cfg: Config, tests: list[FRFTest]) -> list[Branch]:
    """The model's step-sines: ideal source, passive at the test's F_N1, its amplitude and lines."""
    base = with_sets(quiet(cfg), ["shaker.armature_mass_kg=0.0"])
    return [Branch(with_sets(base, [f"tracking.F_passive_N={t.F_N1!r}"]), "passive", float(t.meta["amplitude_n"]),
                   tuple(float(f) for f in t.freq_hz), settle=MODEL_SETTLE, seed=0) for t in tests]


def prepare(cfg: Config, tests: list[FRFTest]) -> StepsineData:
    """Measured ratios and the driving point estimated through the calibrated model ``cfg``."""
    results = run_branches(model_branches(cfg, tests), progress=False, desc="model step-sine")
    R = [t.H["a_frf_meas"] * r.R_exc / r.H_sensors["a_frf_meas"] for t, r in zip(tests, results)]
    return StepsineData(tests, [np.asarray(t.freq_hz, float) for t in tests],
                        [np.asarray(t.F_amp_N, float) / np.asarray(t.drive_amp, float) for t in tests], R)


def residuals(cfg: Config, data: StepsineData) -> np.ndarray:
    """(ln |rho_meas| - ln |rho_model|) / SIGMA over every line, rho_model of cfg's shaker."""
    return np.concatenate([(np.log(rho) - np.log(np.abs(force_ratio(cfg, f, R)))) / SIGMA
                           for f, rho, R in zip(data.freq, data.rho, data.R)])


def gap_db(cfg: Config, data: StepsineData) -> float:
    """RMS of 20 log10 |rho_meas / rho_model| over every line [dB]."""
    return float(np.sqrt(np.mean((SIGMA * residuals(cfg, data) * 20.0 / math.log(10.0)) ** 2)))


def fit_shaker(cfg: Config, data: StepsineData, effect: Effect) -> tuple[float, np.ndarray]:
    """The effect's strength minimising the residuals' sum of squares in its bounds: a grid of
    41 values (uniform in sqrt between the bounds), then ``scipy.optimize.minimize_scalar``
    (bounded) between the grid neighbours of the best. Returns (strength, residuals)."""
    from scipy.optimize import minimize_scalar
    p = effect.parameter

    def cost(s):
        r = residuals(effect.apply(cfg, float(s)), data)
        return float(r @ r)

    grid = p.lo + (p.hi - p.lo) * np.linspace(0.0, 1.0, 41) ** 2
    costs = [cost(s) for s in grid]
    i = int(np.argmin(costs))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    sol = minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 1e-6 * (p.hi - p.lo)})
    s = float(sol.x) if sol.fun <= costs[i] else float(grid[i])
    return s, residuals(effect.apply(cfg, s), data)
