"""Random excitation of the rig's level tests (``frictionrt rig --frf-files --levels .. --excitation random``):
what a lab measures with a shaker driven by band-limited noise, H1 by Welch's method.

Level: the rms F_rms [N] of the force over the band f_lo..f_hi (``frictionrt.rt.discrepancy.rig.levels.BAND_HZ``,
50-1200 Hz; with a force scale s [N/V] the rms V_rms [V] of the drive voltage, the force s v). The
force is Gaussian with the flat one-sided spectral density

    S_ff(f) = F_rms^2 / (f_hi - f_lo)  [N^2/Hz]  on f_lo <= f <= f_hi,  0 outside     (``random_force``)

(white Gaussian noise over the whole record, its DFT set to 0 outside the band, scaled so that the
record's rms is F_rms), held over each plant step as the stepped sine's force (plant.simulate.run, the
adaptive screw, if any, held at F_N1). The record: ``LEAD_S`` of lead-in (dropped: the start from rest
rings the lightly damped modes for seconds), then ``AVERAGES`` Hann-windowed blocks of ``BLOCK_S``
(16 s: 0.0625 Hz lines, a lab's resolution) overlapping by half, (AVERAGES + 1) BLOCK_S / 2 in all.
Each accelerometer's signal a gets white noise of density ``ACC_NOISE`` (an ICP accelerometer's
broadband floor) before the estimator; the force is known exactly (the drive voltage is).

Estimator (scipy.signal.csd / welch, the one-sided densities averaged over the blocks j = 1..n_d,

    S_xy(f) = 2 / (fs sum_k w_k^2 n_d) sum_j conj(X_j(f)) Y_j(f),   X_j the DFT of block j times w (Hann)):

    H1(f)      = S_fa(f) / S_ff(f) e^{-i w dt/2}                [(m/s^2)/N]
    gamma^2(f) = |S_fa(f)|^2 / (S_ff(f) S_aa(f))                 [-], 0..1

a_k the output after step k (at t_{k+1}), the force f_k held over the step (acting, as the stepped sine
takes it, rt.discrepancy.rig.levels, at its middle t_k + dt/2): the factor e^{-i w dt/2} takes out the
half step by which the samples a_k lag the samples f_k. Output noise leaves H1 unbiased; it and the joint's nonlinear
distortion lower gamma^2. The random error of |H1| (Bendat & Piersol, Random Data, 4th ed., Table 9.6):

    eps(|H1|) ~ sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d))                                  (``h1_error``)

with n_d the number of averages (50 % overlapping Hann blocks are nearly independent: their
correlation, 17 %, adds about 5 % to the variance). 10 averages: 2.2 % at gamma^2 = 0.99, 7.5 % at
0.9; a record of 92 s (1.9e6 plant steps: 6-12 s of compiled plant a level on one core, measured,
docs/discrepancy.md). The files hold the lines f_lo <= f <= f_hi of H1 and gamma^2.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.signal import csd, welch

from frictionrt.plant.model import PlantModel
from frictionrt.plant.simulate import run

BLOCK_S = 16.0          # [s] Welch block: 0.0625 Hz lines
AVERAGES = 10           # Hann blocks, 50 % overlap (module docstring: the random error)
OVERLAP = 0.5           # of a block
LEAD_S = 4.0            # [s] lead-in dropped before the first block (the lightly damped modes' start transient)
ACC_NOISE = 1e-4        # [(m/s^2)/sqrt(Hz)] accelerometer noise density (about 10 ug/sqrt(Hz))
CHUNK_S = 1.0           # [s] simulated per call of the plant (the outputs of a whole record would not fit)


class RandomTest(NamedTuple):
    """One level's random test: H1 and the coherence on the band's lines."""
    rms: float               # force rms over the band [N]
    freq_hz: np.ndarray      # (n,) lines [Hz]
    H: dict                  # sensor -> complex (n,) H1 [(m/s^2)/N]
    coherence: dict          # sensor -> (n,) gamma^2 [-]
    averages: int            # Welch blocks n_d
    block_s: float           # Welch block [s]
    sim_s: float             # simulated time [s]


def record_s() -> float:
    """Simulated time of one level [s]: the lead-in and AVERAGES blocks of BLOCK_S overlapping by OVERLAP."""
    return LEAD_S + BLOCK_S * (1.0 + (AVERAGES - 1) * (1.0 - OVERLAP))


def random_force(rms: float, n: int, dt: float, band_hz: tuple[float, float], rng: np.random.Generator) -> np.ndarray:
    """(n,) Gaussian force [N] of rms ``rms`` [N] with a flat spectral density on ``band_hz`` [Hz], none
    outside (module docstring), from ``rng``; step dt [s]."""
    X = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, dt)
    X[(f < band_hz[0]) | (f > band_hz[1])] = 0.0
    x = np.fft.irfft(X, n)
    return rms * x / math.sqrt(np.mean(x * x))


def h1_error(coherence: np.ndarray, averages: int) -> np.ndarray:
    """The normalised random error of |H1|, sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d)) (module docstring)."""
    g2 = np.clip(np.asarray(coherence, float), 1e-12, 1.0)
    return np.sqrt(1.0 - g2) / np.sqrt(g2 * 2.0 * averages)


def h1(force: np.ndarray, response: np.ndarray, dt: float, block_s: float) -> tuple[np.ndarray, ...]:
    """(f [Hz], H1 (m, f) [response unit / N], gamma^2 (m, f)) of the responses (n, m) to the force (n,) by
    Welch's method (module docstring) with blocks of ``block_s`` [s], the force held over each step of dt [s]."""
    fs, nper = 1.0 / dt, int(round(block_s / dt))
    kw = {"fs": fs, "window": "hann", "nperseg": nper, "noverlap": int(round(OVERLAP * nper)), "detrend": False}
    f, S_ff = welch(force, **kw)
    _, S_aa = welch(response.T, **kw)
    _, S_fa = csd(force[None, :], response.T, **kw)
    H = S_fa / S_ff * np.exp(-1j * np.pi * f * dt)
    return f, H, np.abs(S_fa) ** 2 / (S_ff * S_aa)


def random_test(model: PlantModel, F_N1: float, rms: float, band_hz: tuple[float, float], cols: dict[str, int],
                rng: np.random.Generator) -> RandomTest:
    """The random test (module docstring: AVERAGES blocks of BLOCK_S) of ``model`` at the held F_N1 [N] and
    force rms ``rms`` [N] over ``band_hz`` [Hz], the sensors {name: output column}; the force and the
    accelerometer noise from ``rng``."""
    dt = model.cfg.dt_s
    n_lead, n = int(round(LEAD_S / dt)), int(round((record_s() - LEAD_S) / dt))
    force = random_force(rms, n_lead + n, dt, band_hz, rng)
    idx = list(cols.values())
    a = np.empty((n_lead + n, len(idx)))
    x, chunk = model.initial_state(F_N1), int(round(CHUNK_S / dt))
    for k in range(0, n_lead + n, chunk):
        Y, x, _ = run(model, force[k:k + chunk], F_N1, x0=x)
        a[k:k + chunk] = Y[:, idx]
    a = a[n_lead:] + ACC_NOISE * math.sqrt(0.5 / dt) * rng.standard_normal((n, len(idx)))
    f, H, g2 = h1(force[n_lead:], a, dt, BLOCK_S)
    m = (f >= band_hz[0]) & (f <= band_hz[1])
    return RandomTest(float(rms), f[m], {s: H[j, m] for j, s in enumerate(cols)},
                      {s: g2[j, m] for j, s in enumerate(cols)}, AVERAGES, BLOCK_S, (n_lead + n) * dt)
