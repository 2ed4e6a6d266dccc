"""The step-sine channel of the diagnosis (docs/discrepancy.md): the shaker's force ratio.

Data: the step-sine FRF files of a campaign folder (rt.log.frf_files, kind "stepsine", with the columns
F_amp_N and drive_amp_N): per line the measured ratio rho = F_amp / drive. The nominal model's
shaker is an ideal force source, rho = 1.

Model of the candidate ``shaker_interaction`` (armature mass m; the shaker's other constants at
their catalogue values, rt.common.config.Shaker): the two-port of ``frictionrt.plant.shaker.force_ratio``,

    F_exc / drive = 1 / (1 + D_a / k~ + D_a R),

with the structure's driving-point receptance R = w_exc / F_exc at the line estimated as

    R = H_meas * (R_exc / H)_model,

H_meas the measured accelerance a_frf_meas / F_exc, and the bracket the ratio of the two responses
in the calibrated model's own step-sine (ideal source, the test's F_N1, force amplitude and lines:
rt.experiments.stepsine, ``R_exc`` and ``H_sensors``): the same amplitude-dependent (slipping) vibration seen at
the excitation point and at the accelerometer. The stuck linear structure is no substitute there:
near the friction-affected resonances (mode 3 at 200 Hz instead of the stuck 224 Hz at 100 N, 10 N)
the measured accelerance differs from the stuck one by factors 0.04-4.5 and the two-port on the stuck
driving point missed the measured ratio by up to 60 % (0.42 measured, 1.01 predicted at 200 Hz).
Since the shaker leaves a / F_exc unchanged (the force is measured at the structure), the model
needs no shaker for R: one ideal-source simulation per diagnosis, then the fit of m is closed-form
(a grid, then a bounded scalar minimisation).

Residuals (ln |rho_meas| - ln |rho_model|) / sigma_k per line, channel "stepsine F_amp/drive", with

    sigma_k^2 = SIGMA^2 + (DELTA_R |1 - rho_meas,k|)^2,

the propagated error of the driving-point estimate: ln rho moves by S dR/R, S = |rho D_a R|, and
D_a R ~ 1 / rho - 1 (the two-port, k~ >> D_a), so S ~ |1 - rho| from the data alone (the same weights
for every candidate, which keeps BIC's channel term comparable). DELTA_R, the relative error of R, is
per line the larger of DELTA_R_FLOOR and the model's own spread: |ln (R_exc / H)| between the
calibrated model and the same model with its normal contact stiffness k_n x K_N_SPREAD and
/ K_N_SPREAD (k_n is not calibrated: it forms a ridge with k_t, docs/discrepancy.md "What remains").
DELTA_R_FLOOR = 10 %: with the campaign's true structure as the model the estimate is within a few
per cent of the true R; with a calibrated one the errors are larger near driving-point
antiresonances and at the modes next to the armature-on-stinger resonance, where the ratio is most
sensitive to R and would otherwise dominate the fit (docs/studies/discrepancy-campaigns.md).

Lines used: where the calibrated model vibrates as the measurement did, its accelerance |H| within
H_AGREE of the measured one and its shape, the ratio of the two accelerometers' readings
(SHAPE_SENSOR over a_frf_meas), within SHAPE_AGREE of the measured ratio (elsewhere the model is on
another stick-slip branch, or has a resonance or antiresonance a little off, and its R_exc / H says
nothing about the measured R). The shape gate and the k_n spread keep a truth of another model form
(``rig --model-form``) from pulling the fit: next to the stuck modes and at driving-point
antiresonances the calibrated model's R_exc / H can be several times off where |H| agrees within
25 % (docs/studies/discrepancy-campaigns.md has the campaigns that set them).

``gap_db`` uses the same weights (dB at the scale of a well-conditioned line).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.discrepancy.effects import Effect
from frictionrt.rt.log.frf_files import FRFTest, frf_files, load_frf_folder
from frictionrt.rt.discrepancy.chain import quiet
from frictionrt.plant.shaker import force_ratio
from frictionrt.rt.experiments.branches import Branch, run_branches
from frictionrt.rt.experiments.stepsine import Settle

CHANNEL = "stepsine F_amp/drive"
SIGMA = 0.01             # [-] relative: the floor of sigma_k (a well-conditioned line)
DELTA_R_FLOOR = 0.10     # [-] relative error of the driving-point estimate R, at least
K_N_SPREAD = 2.0         # [-] the factor on k_n whose effect on R_exc / H sets a line's DELTA_R beyond the floor
MODEL_SETTLE = Settle(max_s=1.0, rel_tol=0.02)   # the model's lines: a ratio of two responses settles fast
H_AGREE = 0.25           # a line is used only where the model's |H| is within this of the measured one
SHAPE_SENSOR = "a_tip_meas"   # ... and its ratio of this sensor's reading to a_frf_meas ...
SHAPE_AGREE = 0.25       # ... within this of the measured ratio


class StepsineData(NamedTuple):
    tests: list[FRFTest]
    freq: list[np.ndarray]        # per test: lines [Hz]
    rho: list[np.ndarray]         # measured F_amp / drive [-]
    R: list[np.ndarray]           # estimated driving-point receptance [m/N] (complex)
    sigma: list[np.ndarray]       # sigma_k [-] of ln rho per line


def load_stepsine(folder: str | Path) -> list[FRFTest]:
    """The step-sine tests with force and drive amplitudes in the folder (none: []): accelerances per
    newton (the sidecar's default quantity and excitation) of a_frf_meas."""
    if not frf_files(folder):
        return []
    return [t for t in load_frf_folder(folder)
            if t.meta["kind"] == "stepsine" and t.F_amp_N is not None and t.drive_amp is not None
            and t.meta["amplitude_n"] is not None and "a_frf_meas" in t.H
            and (t.quantity, t.excitation) == ("accelerance", "force")]


def model_branches(cfg: Config, tests: list[FRFTest]) -> list[Branch]:
    """The model's step-sines: ideal source, passive at the test's F_N1, its amplitude and lines."""
    base = with_sets(quiet(cfg), ["shaker.armature_mass_kg=0.0"])
    return [Branch(with_sets(base, [f"tracking.F_passive_N={t.F_N1!r}"]), "passive", float(t.meta["amplitude_n"]),
                   tuple(float(f) for f in t.freq_hz), settle=MODEL_SETTLE, seed=0) for t in tests]


def prepare(cfg: Config, tests: list[FRFTest], jobs: int | None = None,
            dask_address: str | None = None) -> StepsineData:
    """Measured ratios and the driving point estimated through the calibrated model ``cfg`` at the
    lines the gates keep (H_AGREE, SHAPE_AGREE where the test has SHAPE_SENSOR), with sigma_k from
    DELTA_R_FLOOR and the spread of R_exc / H over k_n x K_N_SPREAD^{+-1} (module docstring). The
    model's step-sines (3 per test) run in jobs processes or on the dask cluster at dask_address
    (``run_branches``)."""
    k_n = cfg.plant.interface.k_n_area
    variants = [cfg] + [with_sets(cfg, [f"plant.interface.k_n_area={k_n * f!r}"])
                        for f in (K_N_SPREAD, 1.0 / K_N_SPREAD)]
    runs = run_branches([b for c in variants for b in model_branches(c, tests)], jobs, dask_address,
                        progress=False, desc="model step-sine")
    n = len(tests)
    freq, rho, R, sigma = [], [], [], []
    for i, t in enumerate(tests):
        r = runs[i]
        H_meas, H_model = t.H["a_frf_meas"], r.H_sensors["a_frf_meas"]
        keep = np.abs(np.log(np.abs(H_model / H_meas))) <= math.log(1.0 + H_AGREE)
        if SHAPE_SENSOR in t.H:
            shape = (t.H[SHAPE_SENSOR] / H_meas) / (r.H_sensors[SHAPE_SENSOR] / H_model)
            keep &= np.abs(np.log(np.abs(shape))) <= math.log(1.0 + SHAPE_AGREE)
        Q = _transfer(r)
        spread = np.max([np.abs(np.log(np.abs(_transfer(v) / Q))) for v in (runs[n + i], runs[2 * n + i])], axis=0)
        ratio = np.asarray(t.F_amp_N, float) / np.asarray(t.drive_amp, float)
        freq.append(np.asarray(t.freq_hz, float)[keep])
        rho.append(ratio[keep])
        R.append((H_meas * Q)[keep])
        sigma.append(np.sqrt(SIGMA ** 2 + (np.maximum(DELTA_R_FLOOR, spread) * np.abs(1.0 - ratio))[keep] ** 2))
    return StepsineData(tests, freq, rho, R, sigma)


def _transfer(r) -> np.ndarray:
    """R_exc / H of a model step-sine ``r``: the excitation point's receptance over a_frf's accelerance."""
    return r.R_exc / r.H_sensors["a_frf_meas"]


def residuals(cfg: Config, data: StepsineData) -> np.ndarray:
    """(ln |rho_meas| - ln |rho_model|) / sigma_k over every line, rho_model of cfg's shaker."""
    return np.concatenate([(np.log(rho) - np.log(np.abs(force_ratio(cfg, f, R)))) / sig
                           for f, rho, R, sig in zip(data.freq, data.rho, data.R, data.sigma)])


def gap_db(cfg: Config, data: StepsineData) -> float:
    """RMS of 20 log10 |rho_meas / rho_model| (SIGMA / sigma_k) over every line [dB]: the ratio's
    log-magnitude gap, each line weighted as in the fit."""
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
