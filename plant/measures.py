"""Measures of an FRF that a lab would use, and the distances between two FRFs (design time).

Per mode, in a band around it (``mode_bands``):

* the peak: frequency and height of |H|, refined between the bins by a parabola through the
  largest bin and its neighbours in 20 log10 |H| (``peak``);
* the damping ratio by the half-power bandwidth, zeta = (f_b - f_a) / (2 f_peak) with f_a, f_b
  where |H|^2 crosses |H_peak|^2 / 2 (Ewins, *Modal Testing*, 2000, 4.3.2) (``half_power_zeta``),
  and by a one-mode fit (``plant.impulse.fit_mode``) beside it (``mode_measures``);
* the FRF error weighted by the reference's magnitude (``weighted_error_db``)

      e = 10 log10( sum |H - H_ref|^2 / sum |H_ref|^2 )   [dB]

  over the band's lines, so a notch of H_ref (|H_ref| small) weighs little; near a lightly damped
  peak it is dominated by the frequency shift over the half-power band, delta f / (zeta f), so it
  carries no tolerance of its own. The rms of 20 log10 |H / H_ref| (``rms_db``) stays beside it.

A damping ratio on a slip threshold moves with the hammer force (d ln zeta / d ln F up to ~16 on the
joint's thresholds): ``is_off_threshold`` says whether a force lies off one (a +-10 % change of
force changes zeta by less than 10 %), ``threshold_force`` where the steepest change lies.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

HALF_BAND = 0.08          # a mode's band: f0 (1 -+ HALF_BAND), as plant.impulse.identify fits it
FORCE_STEP = 0.10         # off a threshold: zeta at F (1 -+ FORCE_STEP) ...
ZETA_CHANGE = 0.10        # ... differs by less than this (relative)


@dataclass(frozen=True)
class ModeMeasure:
    """One mode's figures from an FRF (NaN where the band holds none)."""
    f_peak_hz: float       # frequency of the largest |H| in the band [Hz]
    peak_abs: float        # |H| there (the FRF's unit)
    zeta_half_power: float  # half-power damping ratio [-]
    f_fit_hz: float        # one-mode fit's natural frequency [Hz]
    zeta_fit: float        # one-mode fit's damping ratio [-]

    def to_dict(self) -> dict:
        return {k: float(v) for k, v in self.__dict__.items()}


def mode_bands(approx_hz, half_band: float = HALF_BAND) -> list[tuple[float, float]]:
    """(lo, hi) [Hz] around each approximate mode frequency: f0 (1 -+ half_band)."""
    return [(f0 * (1.0 - half_band), f0 * (1.0 + half_band)) for f0 in np.asarray(approx_hz, dtype=float)]


def _in_band(freq: np.ndarray, lo: float, hi: float) -> np.ndarray:
    return (freq >= lo) & (freq <= hi)


def peak(freq: np.ndarray, H: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """(f_peak [Hz], |H_peak|) of the largest |H| in [lo, hi]: the vertex of the parabola through
    20 log10 |H| of the largest bin and its two neighbours (the bin itself at a band edge); NaN if
    the band holds fewer than 3 lines."""
    idx = np.flatnonzero(_in_band(freq, lo, hi))
    if len(idx) < 3:
        return math.nan, math.nan
    i = idx[np.argmax(np.abs(H[idx]))]
    if i in (idx[0], idx[-1]):
        return float(freq[i]), float(abs(H[i]))
    y = 20.0 * np.log10(np.abs(H[i - 1:i + 2]))
    den = y[0] - 2.0 * y[1] + y[2]
    d = 0.5 * (y[0] - y[2]) / den if den < 0.0 else 0.0
    d = min(max(d, -0.5), 0.5)
    df = freq[i + 1] - freq[i]
    return float(freq[i] + d * df), float(10.0 ** ((y[1] - 0.25 * (y[0] - y[2]) * d) / 20.0))


def half_power_zeta(freq: np.ndarray, H: np.ndarray, lo: float, hi: float) -> float:
    """Half-power damping ratio [-] of the peak in [lo, hi]: (f_b - f_a) / (2 f_peak), f_a < f_peak
    < f_b the nearest frequencies where |H|^2 falls to half its peak (``peak``'s height), from a
    parabola in 1 / |H|^2 fitted over the lines down to the first below half power on each side; NaN if |H| does not fall to half power inside the band on both sides."""
    f_pk, h_pk = peak(freq, H, lo, hi)
    if not math.isfinite(f_pk):
        return math.nan
    idx = np.flatnonzero(_in_band(freq, lo, hi))
    P = np.abs(H[idx]) ** 2
    f = freq[idx]
    half = 0.5 * h_pk ** 2
    i = int(np.argmax(P))
    below_l = np.flatnonzero(P[:i] < half)
    below_r = np.flatnonzero(P[i + 1:] < half)
    if len(below_l) == 0 or len(below_r) == 0:
        return math.nan
    a = below_l[-1]
    b = i + 1 + below_r[0]
    # near a mode 1 / |H|^2 is a parabola in f (``sdof``: (omega_n^2 - omega^2)^2 + (2 zeta omega_n
    # omega)^2 over omega^4): fitted over the lines a..b, its crossings of 2 / |H_peak|^2
    Q = 1.0 / P[a:b + 1]
    c2, c1, c0 = np.polyfit(f[a:b + 1] - f[i], Q / Q.min(), 2)
    disc = c1 * c1 - 4.0 * c2 * (c0 - 1.0 / (half * Q.min()))
    if c2 <= 0.0 or disc <= 0.0:
        return math.nan
    f_a = f[i] + (-c1 - math.sqrt(disc)) / (2.0 * c2)
    f_b = f[i] + (-c1 + math.sqrt(disc)) / (2.0 * c2)
    return float((f_b - f_a) / (2.0 * f_pk))


def mode_measures(freq: np.ndarray, H: np.ndarray, bands, tau_w: float | None = None) -> list[ModeMeasure]:
    """``ModeMeasure`` of each band (lo, hi) [Hz]. tau_w [s]: the exponential window's time constant
    on the response, whose decay 1 / tau_w is removed from the fitted pole and, to first order
    (zeta_w = zeta + 1 / (tau_w omega)), from the half-power figure; None: no window."""
    from frictionrt.plant.impulse import fit_mode
    out = []
    for lo, hi in bands:
        f_pk, h_pk = peak(freq, H, lo, hi)
        z_hp = half_power_zeta(freq, H, lo, hi)
        f_w, z_w = fit_mode(freq, H, lo, hi)
        if tau_w is not None:
            if math.isfinite(z_hp):
                z_hp -= 1.0 / (tau_w * 2.0 * math.pi * f_pk)
            if math.isfinite(f_w):
                sigma = z_w * 2.0 * math.pi * f_w - 1.0 / tau_w
                omega_d = 2.0 * math.pi * f_w * math.sqrt(max(0.0, 1.0 - z_w ** 2))
                omega_n = math.hypot(sigma, omega_d)
                f_w, z_w = omega_n / (2.0 * math.pi), sigma / omega_n
        out.append(ModeMeasure(f_pk, h_pk, z_hp, float(f_w), float(z_w)))
    return out


def weighted_error_db(H: np.ndarray, H_ref: np.ndarray) -> float:
    """10 log10(sum |H - H_ref|^2 / sum |H_ref|^2) [dB] (module docstring); -inf if H == H_ref."""
    num = float(np.sum(np.abs(H - H_ref) ** 2))
    return 10.0 * math.log10(num / float(np.sum(np.abs(H_ref) ** 2))) if num > 0.0 else -math.inf


def band_errors_db(freq: np.ndarray, H: np.ndarray, H_ref: np.ndarray, bands) -> list[float]:
    """``weighted_error_db`` over each band (lo, hi) [Hz] of the lines ``freq`` of H and H_ref."""
    return [weighted_error_db(H[s], H_ref[s]) for s in (_in_band(freq, lo, hi) for lo, hi in bands)]


def rms_db(H: np.ndarray, H_ref: np.ndarray) -> float:
    """RMS of 20 log10 |H / H_ref| [dB]."""
    return float(np.sqrt(np.mean((20.0 * np.log10(np.abs(H / H_ref))) ** 2)))


def is_off_threshold(zeta_lo: float, zeta_hi: float, zeta_change: float = ZETA_CHANGE) -> bool:
    """True if zeta at F (1 - FORCE_STEP) and at F (1 + FORCE_STEP) [-] differ by less than
    zeta_change relative to their mean: the figure at F is off a slip threshold."""
    if not (math.isfinite(zeta_lo) and math.isfinite(zeta_hi)):
        return False
    return abs(zeta_hi - zeta_lo) < zeta_change * 0.5 * (zeta_hi + zeta_lo)


def threshold_force(forces, zetas) -> tuple[float, float]:
    """(F_threshold [N], slope) of a damping ratio against the force: the geometric middle of the
    neighbouring forces between which d ln zeta / d ln F (the slope) is largest in magnitude.
    forces increasing, > 0; zetas > 0 (a NaN interval is skipped); NaN if no interval is finite."""
    F = np.asarray(forces, dtype=float)
    z = np.asarray(zetas, dtype=float)
    if len(F) < 2 or np.any(np.diff(F) <= 0) or np.any(F <= 0):
        raise ValueError(f"forces {list(F)}: give two or more increasing forces > 0 N")
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.diff(np.log(z)) / np.diff(np.log(F))
    ok = np.isfinite(slope)
    if not ok.any():
        return math.nan, math.nan
    k = int(np.flatnonzero(ok)[np.argmax(np.abs(slope[ok]))])
    return float(math.sqrt(F[k] * F[k + 1])), float(slope[k])
